//! What a renderer records for training: one path segment with its contribution and pdfs.

use glam::Vec3;
use serde::{Deserialize, Serialize};

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
    /// segment alone (see [`crate::gmm::PointsConfig::extend_through_refraction`]).
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
}
