//! Giving guiding up: after every guided training iteration of a time-budget render, the guided images
//! so far are compared with the unguided first iteration's
//! ([`cross_check`](super::cross_check::cross_check)); where guiding costs more than it gains, the rest
//! of the budget is rendered unguided ([`fallback_threshold`], [`gives_up`]), and the guided iterations
//! rendered before keep their share of the output ([`fallback_weights`]).

use super::combine::{robust_inverse_variance_weights, IterationImage};
use super::cross_check::CrossCheck;
use super::iteration::{moment_ratio, IterationStats};
use crate::film::Image;

/// A time-budget render compares the guided iterations with the unguided first one ([`cross_check`](super::cross_check::cross_check))
/// after every guided training iteration, but gives guiding up only from this check on (0-based): the
/// first checks rest on a guide that has learned little and on images of two samples per pixel, and in
/// a dim room an iteration that missed the light looks as quiet as the Cornell box. Waiting costs a
/// non-focal scene a few guided iterations, whose images the fallback's combination keeps
/// ([`fallback_weights`]). Measured in docs/experiments/2026-12-07-decisions-missing-the-light.md.
pub const FIRST_DECISIVE_CHECK: usize = 2;

/// Guiding is given up at the first decisive check where its inefficiency (relative error × time) is
/// more than this many times the path tracer's, or [`LATER_THRESHOLD`] at later checks: there the image
/// check also climbs on focal scenes during iterative narrowing, where guiding still wins.
pub const FIRST_THRESHOLD: f64 = 1.0;
/// The threshold of the checks after the first decisive one.
pub const LATER_THRESHOLD: f64 = 2.0;
/// The first decisive check's threshold where the guided vertices' pooled second-moment ratio
/// ([`IterationStats::moments`], BSDF alone over the mixture) is below 1, i.e. where the guide adds
/// local variance rather than finding what the BSDF misses (as on veach-mis).
pub const FIRST_THRESHOLD_WITHOUT_MOMENT_GAIN: f64 = 0.5;

/// Where the guided vertices' pooled second-moment ratio (BSDF alone over the mixture) is at least this,
/// guiding is never given up: the guide finds light the BSDF finds rarely, and the image check is then
/// at the mercy of whether the few samples behind it saw that light. The non-focal scenes stay below it
/// and a focal scene's ratio jumps far above it once its guide finds the light
/// (docs/experiments/2026-12-07-decisions-missing-the-light.md).
pub const MOMENT_GAIN_TO_KEEP_GUIDING: f64 = 2.0;

/// The threshold of the `check`-th fallback check (0-based) given the pooled second-moment ratio of the
/// guided iterations so far (`None` without guided segments): infinity (no decision) before
/// [`FIRST_DECISIVE_CHECK`] and where the ratio is at least [`MOMENT_GAIN_TO_KEEP_GUIDING`], else
/// [`FIRST_THRESHOLD`] (or [`FIRST_THRESHOLD_WITHOUT_MOMENT_GAIN`]) at the first decisive check and
/// [`LATER_THRESHOLD`] after it.
pub fn fallback_threshold(check: usize, moment_ratio: Option<f64>) -> f64 {
    match moment_ratio {
        _ if check < FIRST_DECISIVE_CHECK => f64::INFINITY,
        Some(r) if r >= MOMENT_GAIN_TO_KEEP_GUIDING => f64::INFINITY,
        Some(r) if r < 1.0 && check == FIRST_DECISIVE_CHECK => FIRST_THRESHOLD_WITHOUT_MOMENT_GAIN,
        _ if check == FIRST_DECISIVE_CHECK => FIRST_THRESHOLD,
        _ => LATER_THRESHOLD,
    }
}

/// Whether a check gives guiding up: its inefficiency ratio is finite and above `threshold`. A ratio that
/// is not finite says the comparison had nothing to go on (no light in either image, or a path tracer's
/// error estimated at zero): guiding goes on.
pub fn gives_up(check: &CrossCheck, threshold: f64) -> bool {
    check.inefficiency_ratio.is_finite() && check.inefficiency_ratio > threshold
}

/// The pooled ratio of [`IterationStats::moments`] over `iterations` (BSDF alone over the mixture), if
/// any guided segment was recorded.
pub(super) fn pooled_moment_ratio<'a>(
    iterations: impl Iterator<Item = &'a IterationStats>,
) -> Option<f64> {
    moment_ratio(iterations.fold([0.0f64; 2], |acc, s| {
        [acc[0] + s.moments[0], acc[1] + s.moments[1]]
    }))
}

/// The fallback decision of a render.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Fallback {
    /// The comparison it was made on.
    pub check: CrossCheck,
    /// The check's threshold ([`fallback_threshold`]; infinite where it could not give guiding up).
    pub threshold: f64,
    /// The render went on unguided (inefficiency ratio above the check's threshold,
    /// [`fallback_threshold`]).
    pub fell_back: bool,
}

/// The combination weights of a render that gave guiding up (`images` and `rendered` in render order):
/// the unguided iterations are one estimator (the path tracer), pooled by their samples and placed
/// last, after the guided iterations that preceded the fallback; [`robust_inverse_variance_weights`]
/// then weighs the guided ones by their variance, never above their share of the samples next to the
/// path tracer (the more efficient estimator here, or guiding would not have been given up). Their images
/// are unbiased: keeping them makes the checks before a fallback cost less than their time.
pub fn fallback_weights(images: &[IterationImage], rendered: &[&IterationStats]) -> Vec<f64> {
    let mut order: Vec<IterationImage> = Vec::new();
    let mut cost: Vec<f64> = Vec::new();
    for (image, _) in images.iter().zip(rendered).filter(|(_, s)| s.guided) {
        order.push(image.clone());
        cost.push(image.spp() as f64);
    }
    let unguided: Vec<(&IterationImage, &&IterationStats)> = images
        .iter()
        .zip(rendered)
        .filter(|(_, s)| !s.guided)
        .collect();
    let unguided_spp: f64 = unguided.iter().map(|(i, _)| i.spp() as f64).sum();
    if unguided_spp > 0.0 {
        order.push(pooled_halves(unguided.iter().map(|(i, _)| *i)));
        cost.push(unguided_spp);
    }
    let w = robust_inverse_variance_weights(&order, &cost);
    let pool_weight = if unguided_spp > 0.0 {
        w[w.len() - 1]
    } else {
        0.0
    };
    let mut guided_weights = w.into_iter();
    images
        .iter()
        .zip(rendered)
        .map(|(image, s)| {
            if s.guided {
                guided_weights.next().unwrap_or(0.0)
            } else {
                pool_weight * image.spp() as f64 / unguided_spp
            }
        })
        .collect()
}

/// Several iterations of one estimator as one: each half is the sample-weighted mean of theirs.
pub(super) fn pooled_halves<'a>(its: impl Iterator<Item = &'a IterationImage>) -> IterationImage {
    let its: Vec<&IterationImage> = its.collect();
    let half = |pick: fn(&IterationImage) -> &(Image, u32)| -> (Image, u32) {
        let n: u32 = its.iter().map(|i| pick(i).1).sum();
        let mut out: Option<Image> = None;
        for it in &its {
            let (img, k) = pick(it);
            if *k == 0 {
                continue;
            }
            let w = *k as f64 / n as f64;
            match &mut out {
                None => {
                    let mut i = img.clone();
                    i.scale(w);
                    out = Some(i);
                }
                Some(o) => o.add_scaled(img, w),
            }
        }
        (out.unwrap_or_else(|| Image::new(0, 0)), n)
    };
    IterationImage {
        a: half(|i| &i.a),
        b: half(|i| &i.b),
    }
}
