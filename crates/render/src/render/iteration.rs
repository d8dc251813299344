//! What one iteration of a guided render did, as the render's JSON record reports it.

use super::cross_check::CrossCheck;
use focal_guiding::UpdateStats;

/// What happened in one iteration, for the JSON record.
#[derive(Clone, Debug, serde::Serialize)]
pub struct IterationStats {
    /// 0 = the first, unguided iteration.
    pub index: u32,
    /// Rendered with a guide.
    pub guided: bool,
    /// Recorded training data (all but the final iteration).
    pub training: bool,
    /// Samples per pixel.
    pub spp: u32,
    /// Wall time of the rendering.
    pub render_s: f64,
    /// Pixel samples per second.
    pub samples_per_s: f64,
    /// Training segments recorded.
    pub segments: u64,
    /// Guided training iterations: over the recorded guided segments, the estimated second moment of
    /// sampling each one's direction by the BSDF alone (guide fraction 0) over that of the mixture it was
    /// sampled with (`TrainingSegment::second_moment_with_fraction`: NEE-aware emission, per-pixel
    /// weights): above 1 where the guide finds contributions the BSDF misses. Kept as its two sums, the
    /// mixture's and the BSDF's (so that iterations can be pooled); the JSON record holds the ratio, or
    /// null without guided segments.
    #[serde(
        rename = "bsdf_moment_ratio",
        serialize_with = "serialize_moment_ratio"
    )]
    pub moments: [f64; 2],
    /// Training iterations: the effective number of contributing segments, (Σ c)² / Σ c² over the
    /// recorded segments' contributions c (pixel-weighted): how many segments the training data rests
    /// on. A handful where the light was found only by rare paths; many where it is easy to find.
    pub effective_segments: f64,
    /// Wall time the guide spent taking this iteration's segments (between passes).
    pub record_s: f64,
    /// The guide update that followed (training iterations only).
    pub update: Option<UpdateStats>,
    /// Weight of this iteration in the output image.
    pub weight: f64,
    /// Guided training iterations: the image-space comparison of the guided iterations so far with the
    /// unguided first one ([`cross_check`]).
    pub cross_check: Option<CrossCheck>,
}

/// Writes [`IterationStats::moments`] as their ratio.
fn serialize_moment_ratio<S: serde::Serializer>(m: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&moment_ratio(*m), s)
}

/// The BSDF's over the mixture's second moment from their sums `[mixture, bsdf]`
/// ([`IterationStats::moments`]), if there was a guided segment and the sum is finite.
pub fn moment_ratio([mix, bsdf]: [f64; 2]) -> Option<f64> {
    (mix > 0.0 && bsdf.is_finite()).then(|| bsdf / mix)
}
