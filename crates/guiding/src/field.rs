//! The interface every guide implements, shaped like Open PGL's `Field`: a learned model that a
//! renderer queries through a per-thread [`SamplingDistribution`], and that it updates between
//! iterations from a [`SampleStorage`] of the training segments it recorded.
//!
//! One iteration of a renderer, in calls:
//!
//! ```text
//! let mut samples = field.new_samples();            // the iteration's training-sample storage
//! // per thread, per shading point x (the model is read-only while rendering):
//! field.init(&mut distribution, x, normal);         // distribution: one per thread, reused
//! field.sample(&distribution, u); field.pdf(&distribution, direction);
//! // between render passes, in a fixed order:
//! field.add_samples(&mut samples, &segments);
//! // after the iteration:
//! field.update(samples, &context);                  // the next model
//! ```

use std::any::Any;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::{Aabb3, SampleStorage, SamplingDistribution, TrainingSegment};

/// A direction proposed by a guide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideSample {
    /// Unit direction.
    pub direction: Vec3,
    /// Its solid-angle pdf: exactly what [`GuidingField::pdf`] returns for it from the same
    /// distribution.
    pub pdf: f32,
}

/// What the renderer tells a field when it updates it between iterations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateContext {
    /// Index of the iteration whose segments are passed (0 = the first, unguided one).
    pub iteration: u32,
    /// Number of training iterations planned (the final render iteration excluded), for the
    /// [`crate::Schedule`] ("iterative narrowing from ⌊2N/3⌋").
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

/// A learned spatial density used to guide path directions (Open PGL's `Field`).
///
/// `normal`: when the caller will only use directions in the hemisphere around `normal` (an opaque
/// reflective BSDF), a field may restrict sampling to that hemisphere; it must then return the pdf of
/// that restricted sampler. `None` means the whole sphere.
///
/// Sampling and pdf evaluation read the model only, so one field serves every render thread; each
/// thread keeps its own [`SamplingDistribution`]. Training never changes the model either until
/// [`GuidingField::update`]: the segments of an iteration go to a [`SampleStorage`] that the renderer
/// owns, apart from the field.
pub trait GuidingField: Send + Sync {
    /// Short method name ("octree", "gmm").
    fn name(&self) -> &'static str;

    /// The (padded) scene box the field covers.
    fn aabb(&self) -> Aabb3;

    /// Prepares `distribution` for queries at the shading point `x` with hemisphere hint `normal`:
    /// everything that depends on the point alone is computed here once (the GMM's per-component
    /// kernel terms and hemisphere masses, which next-event estimation, sampling and the BSDF
    /// direction's pdf all need).
    fn init(&self, distribution: &mut SamplingDistribution, x: Vec3, normal: Option<Vec3>);

    /// Samples a direction with three uniform numbers from a distribution made by
    /// [`GuidingField::init`]; `None` if nothing can be sampled (an untrained field, an empty
    /// hemisphere).
    fn sample(&self, distribution: &SamplingDistribution, u: [f32; 3]) -> Option<GuideSample>;

    /// The exact solid-angle pdf of [`GuidingField::sample`] producing the unit `direction` from a
    /// distribution made by [`GuidingField::init`].
    fn pdf(&self, distribution: &SamplingDistribution, direction: Vec3) -> f32;

    /// [`GuidingField::sample`] at one point, with a distribution of its own (for tests and tools; a
    /// renderer keeps one distribution per thread instead).
    fn sample_at(&self, x: Vec3, normal: Option<Vec3>, u: [f32; 3]) -> Option<GuideSample> {
        let mut distribution = SamplingDistribution::default();
        self.init(&mut distribution, x, normal);
        self.sample(&distribution, u)
    }

    /// [`GuidingField::pdf`] at one point, with a distribution of its own.
    fn pdf_at(&self, x: Vec3, normal: Option<Vec3>, direction: Vec3) -> f32 {
        let mut distribution = SamplingDistribution::default();
        self.init(&mut distribution, x, normal);
        self.pdf(&distribution, direction)
    }

    /// The probability with which a renderer should sample this guide rather than the BSDF at `x`, if
    /// the field has its own (a fixed one, or one learned per region: [`crate::SelectionLayer`]);
    /// `None` leaves the renderer's fixed fraction. At 0 the renderer samples the BSDF alone, except
    /// at a random [`crate::EXPLORATION_PROBABILITY`] share of such vertices, where it uses
    /// [`crate::EXPLORATION_FRACTION`] so that the field keeps learning there. `glossy` tells a vertex
    /// whose BSDF has a narrow lobe (min roughness below the glossy threshold), where a learned fraction
    /// may not apply.
    fn selection_probability(&self, x: Vec3, glossy: bool) -> Option<f32> {
        let _ = (x, glossy);
        None
    }

    /// An empty training-sample storage for the current model.
    fn new_samples(&self) -> SampleStorage;

    /// Adds one batch of the current iteration's training segments to `samples`. A renderer calls it
    /// between render passes, with batches in a deterministic order. What a field keeps of a segment
    /// may depend on the model the segment was rendered with (the octree splats it into its current
    /// leaves), which is why the field, read-only, does it.
    fn add_samples(&self, samples: &mut SampleStorage, segments: &[TrainingSegment]);

    /// Learns from `samples` (made by this field's [`GuidingField::new_samples`] since the last update)
    /// and rebuilds the model. Deterministic: the same batches and context give a bit-identical model
    /// for any number of threads.
    fn update(&mut self, samples: SampleStorage, context: &UpdateContext) -> UpdateStats;

    /// One update from a single batch of segments.
    fn update_with(
        &mut self,
        segments: &[TrainingSegment],
        context: &UpdateContext,
    ) -> UpdateStats {
        let mut samples = self.new_samples();
        self.add_samples(&mut samples, segments);
        self.update(samples, context)
    }

    /// Updates applied so far (Open PGL's `GetIteration`).
    fn updates(&self) -> u32;

    /// A versioned binary snapshot of the model (not of the configuration: a loader takes that as an
    /// argument, see the implementations' `load`).
    fn save(&self) -> Vec<u8>;

    /// The guide itself, behind any layers, for tools that show a particular guide's structure
    /// (`downcast_ref::<GmmGuide>()`).
    fn as_any(&self) -> &dyn Any;
}
