//! The interface every guiding distribution implements.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// An axis-aligned box (the scene bounds a distribution may cover).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb3 {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb3 {
    /// The box made usable as a guide's domain: an error naming `owner` if it is not finite or empty; an
    /// axis of zero extent (a flat scene) padded to 1e-3 of the largest extent (or 1 if all are zero) so
    /// that every cell and every normalisation has a positive volume.
    pub fn padded(self, owner: &str) -> Result<Aabb3, String> {
        if !self.min.is_finite() || !self.max.is_finite() || self.min.cmpgt(self.max).any() {
            return Err(format!(
                "{owner} needs a finite non-empty box, got {:?}..{:?}",
                self.min, self.max
            ));
        }
        let extent = self.max - self.min;
        let largest = extent.max_element();
        let pad = if largest > 0.0 { largest * 1e-3 } else { 1.0 };
        let mut out = self;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                out.min[axis] -= pad / 2.0;
                out.max[axis] += pad / 2.0;
            }
        }
        Ok(out)
    }
}

/// Checks the magic and version of a decoded guide snapshot; `kind` names it in the error ("octree
/// guide", "GMM guide").
pub(crate) fn check_snapshot_header(
    kind: &str,
    magic: [u8; 8],
    expected_magic: [u8; 8],
    version: u32,
    expected_version: u32,
) -> Result<(), String> {
    if magic != expected_magic {
        return Err(format!("not {} {kind} snapshot (bad magic)", article(kind)));
    }
    if version != expected_version {
        return Err(format!(
            "{kind} snapshot version {version} is not supported (expected {expected_version})"
        ));
    }
    Ok(())
}

/// "an" before a vowel sound as the error messages spell them, "a" otherwise.
fn article(kind: &str) -> &'static str {
    if kind.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    }
}

/// One path segment recorded for training ("training data", `docs/design/octree.md` §3): a segment
/// leaving a non-delta vertex that hit a surface.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingSegment {
    /// The vertex x_k the direction was sampled at.
    pub origin: Vec3,
    /// The sampled unit direction ω.
    pub direction: Vec3,
    /// Distance to the next vertex x_{k+1}.
    pub distance: f32,
    /// The segment's scalar contribution c: the RGB mean of throughput × sampling weight × radiance
    /// returned through ω (MIS-weighted emission at x_{k+1} plus everything deeper, excluding NEE at x_k).
    pub weight: f32,
    /// The full sampling pdf p_mix(ω) used at x_k (BSDF/guide mixture, or BSDF alone when unguided).
    pub pdf: f32,
    /// The BSDF's own sampling pdf of ω at x_k (equal to `pdf` when unguided). With `pdf` it tells a
    /// renderer what sampling ω by the BSDF alone would have cost: the segment's second moment under
    /// BSDF sampling is c²·pdf/bsdf_pdf (c sampled with `pdf`).
    pub bsdf_pdf: f32,
    /// The guide's own pdf of ω at x_k (0 when the vertex was not guided).
    pub guide_pdf: f32,
    /// The probability α with which the guide rather than the BSDF was sampled at x_k, so that
    /// `pdf` = α·`guide_pdf` + (1 − α)·`bsdf_pdf` (0 when the vertex was not guided).
    pub guide_fraction: f32,
    /// True if the endpoint x_{k+1} is glossy (min roughness < 0.3): a virtual image is possible, so the
    /// whole forward line is a converging candidate and the backward line a diverging one.
    pub glossy_endpoint: bool,
    /// True if the vertex x_k itself is glossy (min roughness below the glossy threshold), where a
    /// learned selection fraction may not apply.
    #[serde(default)]
    pub glossy_origin: bool,
    /// True if the endpoint x_{k+1} is glossy glass through which the path refracted and left at more
    /// than about 10° from this segment's direction (a lens or a ball rather than a window): the line
    /// through x_{k+1} then does not point where the light came from, and a guide may train on the
    /// segment alone (see [`crate::GmmConfig::extend_through_refraction`]).
    #[serde(default)]
    pub refracting_endpoint: bool,
    /// The part of `weight` that is emission found at x_{k+1} itself, MIS-weighted against next-event
    /// estimation (0 if x_{k+1} emits nothing, or through a delta vertex where NEE cannot compete).
    pub emitted: f32,
    /// Next-event estimation's solid-angle pdf at x_k of the emission in `emitted` (0 without it); that
    /// emission's MIS weight was the power heuristic pdf²/(pdf² + emitter_pdf²).
    pub emitter_pdf: f32,
    /// The renderer's weight of the path's pixel, 1/(I² + ε) with I the pixel's estimate so far, so that
    /// second moments weigh every pixel's relative error alike, as relMSE does (1 when unknown).
    pub pixel_weight: f32,
    /// The RGB mean of the path throughput at x_k before ω was sampled (0 when unknown): `weight` /
    /// `throughput` is the one-sample estimate of the radiance x_k reflects towards the path.
    #[serde(default)]
    pub throughput: f32,
}

/// A direction proposed by a guide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideSample {
    /// Unit direction.
    pub direction: Vec3,
    /// Its solid-angle pdf under the same `normal` argument (exactly [`GuidingDistribution::pdf`]).
    pub pdf: f32,
}

/// What the renderer tells a distribution when it updates it between iterations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateContext {
    /// Index of the iteration whose segments are passed (0 = the first, unguided one).
    pub iteration: u32,
    /// Number of training iterations planned (the final render iteration excluded), for schedules such as
    /// "iterative narrowing from ⌊2N/3⌋".
    pub training_iterations: u32,
    /// True if the next iteration is the final render (no more training follows).
    pub final_build: bool,
    /// Worker threads the update may use (0 = all).
    pub threads: usize,
}

/// Statistics of one update, for the render's JSON record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UpdateStats {
    /// Segments consumed.
    pub segments: u64,
    /// Model size after the update (octree leaves, mixture components, ...).
    pub model_size: u64,
    /// Wall time of the update in seconds.
    pub seconds: f64,
    /// Free-form details (per method).
    pub details: Vec<(String, f64)>,
}

/// What a distribution computes once per shading point and reuses for every [`GuidingDistribution::sample_at`]
/// and [`GuidingDistribution::pdf_at`] call there (the GMM's per-component hemisphere masses, needed by
/// next-event estimation, sampling and the BSDF direction's pdf alike). Keep one per thread and reuse it
/// across vertices and paths so its buffers are allocated once: `sample_at` and `pdf_at` may read only what
/// the last `prepare` wrote (the buffers still hold an earlier vertex's values, maybe another guide's).
#[derive(Clone, Debug, Default)]
pub struct GuideVertex {
    /// The shading point.
    pub x: Vec3,
    /// The hemisphere hint, as the `normal` of [`GuidingDistribution::sample`].
    pub normal: Option<Vec3>,
    /// Scalars the implementation keeps here.
    pub scalars: [f64; 4],
    /// A buffer the implementation keeps here.
    pub buffer: Vec<f64>,
    /// A single-precision buffer the implementation keeps here (the GMM's per-component terms of its
    /// `f32` pdf kernel).
    pub buffer32: Vec<f32>,
}

/// A learned spatial density used to guide path directions.
///
/// `normal`: when the caller will only use directions in the hemisphere around `normal` (an opaque
/// reflective BSDF), a distribution may restrict sampling to that hemisphere; it must then return the pdf
/// of that restricted sampler, and the caller must pass the same `normal` to `pdf`. `None` means the whole
/// sphere.
pub trait GuidingDistribution: Send + Sync {
    /// Short method name ("octree", "gmm").
    fn name(&self) -> &'static str;

    /// Samples a direction from `x` with three uniform numbers; `None` if nothing can be sampled (e.g. an
    /// untrained distribution or an empty hemisphere).
    fn sample(&self, x: Vec3, normal: Option<Vec3>, u: [f32; 3]) -> Option<GuideSample>;

    /// The exact solid-angle pdf of [`GuidingDistribution::sample`] producing unit direction `d` from `x`.
    fn pdf(&self, x: Vec3, normal: Option<Vec3>, d: Vec3) -> f32;

    /// Prepares `vertex` for queries at `x` with hemisphere hint `normal`. Then `sample_at` and `pdf_at`
    /// must return exactly what `sample` and `pdf` return for the same `x` and `normal`.
    fn prepare(&self, x: Vec3, normal: Option<Vec3>, vertex: &mut GuideVertex) {
        vertex.x = x;
        vertex.normal = normal;
    }

    /// [`GuidingDistribution::sample`] at a vertex made by [`GuidingDistribution::prepare`].
    fn sample_at(&self, vertex: &GuideVertex, u: [f32; 3]) -> Option<GuideSample> {
        self.sample(vertex.x, vertex.normal, u)
    }

    /// [`GuidingDistribution::pdf`] at a vertex made by [`GuidingDistribution::prepare`].
    fn pdf_at(&self, vertex: &GuideVertex, d: Vec3) -> f32 {
        self.pdf(vertex.x, vertex.normal, d)
    }

    /// True if the distribution also wants the segments whose continuation carried nothing (weight 0):
    /// a guide that needs every vertex's mean contribution (the GMM's MIS compensation) counts them.
    /// False by default: such segments teach the other guides nothing.
    fn wants_empty_segments(&self) -> bool {
        false
    }

    /// The probability with which a renderer should sample this guide rather than the BSDF at `x`, if
    /// the distribution has its own (a fixed one, or one learned per region: [`crate::SelectionGrid`]);
    /// `None` leaves the renderer's fixed fraction. At 0 the renderer samples the BSDF alone, except at a random
    /// [`crate::EXPLORATION_PROBABILITY`] share of such vertices, where it uses
    /// [`crate::EXPLORATION_FRACTION`] so that the distribution keeps learning there. `glossy` tells a
    /// vertex whose BSDF has a narrow lobe (min roughness below the glossy threshold), where a learned
    /// fraction may not apply.
    fn selection_probability(&self, x: Vec3, glossy: bool) -> Option<f32> {
        let _ = (x, glossy);
        None
    }

    /// Takes one batch of the current iteration's training segments. The renderer calls it between
    /// render passes, with batches in a deterministic order; it must not change what `sample` and `pdf`
    /// return (the model stays fixed for the whole iteration) until the next `update`.
    fn record(&mut self, segments: &[TrainingSegment]);

    /// Learns from everything recorded since the last update and rebuilds the model.
    /// Deterministic: the same batches and context give a bit-identical model for any `threads`.
    fn update(&mut self, ctx: &UpdateContext) -> UpdateStats;

    /// A versioned binary snapshot of the model (see the implementation's `load`).
    fn save(&self) -> Vec<u8>;
}
