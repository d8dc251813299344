//! Combining the images of a guided render's iterations into one estimate.
//!
//! Every iteration's image is an unbiased estimate of the same image, rendered with a different (better
//! and better) guide. Rath et al. keep only the last one ([`Combine::Last`]); Müller et al. weight each
//! iteration by the inverse of its variance. We estimate an iteration's variance from the difference of
//! its two interleaved halves (even and odd sample indices), relative to the pooled image as relMSE does,
//! so bright pixels do not dominate:
//!
//!   v_i = mean_p [ mean_c (A_p − B_p)² · n_A n_B / n_i² ] / (pooled_p² + ε Ī²),   ε = 1e-2,
//!
//! with Ī the pooled image's mean brightness (the exposure). That estimate is what an iteration that
//! missed the light gets wrong: its few samples per pixel miss the rare bright paths in both halves, so
//! it looks quiet exactly when its image is too dark, and plain inverse-variance weights hand it the
//! weight of the iterations that found the light. So the weights do not trust an iteration to be more
//! efficient than the final one: each iteration's inefficiency (variance × cost) is raised to
//! at least the final iteration's ([`robust_inverse_variance_weights`]), since the guide only improves
//! from one iteration to the next and the final iteration, the largest, has the most reliable estimate.
//! An iteration can then not weigh more, relative to the final one, than its share of the cost (the
//! samples): the combination falls back to sample-count weights, which are unbiased, wherever the
//! variance estimates would have favoured an earlier one. Iterations whose (raised) inefficiency is
//! above [`MAX_RELATIVE_INEFFICIENCY`] times the final iteration's are left out. An iteration without a
//! variance estimate (under two samples per pixel, or all black) counts as the least efficient one.
//! The guided renderer leaves the unguided first iteration out whenever a guided one exists. The
//! weights come from the same samples, so the combination is consistent rather than exactly unbiased;
//! `Combine::Last` is exactly unbiased.

use crate::film::Image;

/// Iterations whose inefficiency (relative variance × render time) is above this many times the final
/// iteration's are left out: their guide was too poor to matter.
pub const MAX_RELATIVE_INEFFICIENCY: f64 = 20.0;
/// The ε of the relative variance, relative to the pooled image's squared mean brightness (as the
/// benchmark's exposure-normalised relMSE).
pub const RELATIVE_EPSILON: f64 = 1e-2;

/// How a guided render turns its iterations' images into the output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Combine {
    /// The final iteration's image only (Rath et al. 2023).
    Last,
    /// Inverse-variance weighting of the iterations (see the module documentation).
    InverseVariance,
}

/// One iteration's image as two interleaved halves with their sample counts.
#[derive(Clone, Debug)]
pub struct IterationImage {
    /// Half of even sample indices, and its samples per pixel.
    pub a: (Image, u32),
    /// Half of odd sample indices, and its samples per pixel.
    pub b: (Image, u32),
}

impl IterationImage {
    /// Samples per pixel.
    pub fn spp(&self) -> u32 {
        self.a.1 + self.b.1
    }

    /// The iteration's image (sample-count weighted mean of the halves).
    pub fn image(&self) -> Image {
        let n = self.spp().max(1) as f64;
        let mut img = self.a.0.clone();
        img.scale(self.a.1 as f64 / n);
        if self.b.1 > 0 {
            img.add_scaled(&self.b.0, self.b.1 as f64 / n);
        }
        img
    }
}

/// The relative variance estimate v_i of each iteration against `pooled` (`None` below 2 spp): the
/// per-sample variance of its two halves divided by its samples per pixel.
pub fn relative_variances(iterations: &[IterationImage], pooled: &Image) -> Vec<Option<f64>> {
    let epsilon = relative_epsilon(pooled);
    iterations
        .iter()
        .map(|it| {
            per_sample_relative_variance(&it.a.0, it.a.1, &it.b.0, it.b.1, pooled, epsilon)
                .map(|v| v / it.spp() as f64)
        })
        .collect()
}

/// The ε of relative errors against `pooled`: [`RELATIVE_EPSILON`] times its squared mean brightness
/// (or [`RELATIVE_EPSILON`] itself for a black image), so that relative errors do not depend on the
/// scene's exposure.
pub fn relative_epsilon(pooled: &Image) -> f64 {
    let n = pooled.rgb.len().max(1) as f64;
    let mean = pooled
        .rgb
        .iter()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .sum::<f64>()
        / n;
    if mean > 0.0 && mean.is_finite() {
        RELATIVE_EPSILON * mean * mean
    } else {
        RELATIVE_EPSILON
    }
}

/// The relative per-sample variance σ² of an estimator, from two independent images of it (`a` with
/// `na` samples per pixel, `b` with `nb`): Var(A − B) = σ²(1/na + 1/nb) per pixel and channel, each
/// pixel's divided by pooled² + `epsilon`, averaged over the image. `None` if either image has no samples.
pub fn per_sample_relative_variance(
    a: &Image,
    na: u32,
    b: &Image,
    nb: u32,
    pooled: &Image,
    epsilon: f64,
) -> Option<f64> {
    if na == 0 || nb == 0 {
        return None;
    }
    let scale = 1.0 / (1.0 / na as f64 + 1.0 / nb as f64);
    let mut sum = 0.0f64;
    for ((pa, pb), pp) in a.rgb.iter().zip(&b.rgb).zip(&pooled.rgb) {
        let mut d2 = 0.0f64;
        let mut m = 0.0f64;
        for c in 0..3 {
            let d = pa[c] as f64 - pb[c] as f64;
            d2 += d * d;
            m += pp[c] as f64;
        }
        let m = m / 3.0;
        sum += d2 / 3.0 * scale / (m * m + epsilon);
    }
    let v = sum / pooled.rgb.len().max(1) as f64;
    v.is_finite().then_some(v)
}

/// The combination weights of `iterations` (in render order, each with its `cost`), normalised to sum
/// to 1 (0 for iterations left out): inverse variance with each iteration's inefficiency (relative
/// variance × cost) raised to at least the final one's (see the module documentation). The renderer
/// passes sample counts as the cost, not measured seconds, so that a fixed seed gives the same image
/// whatever the machine's load and thread count.
pub fn robust_inverse_variance_weights(iterations: &[IterationImage], cost: &[f64]) -> Vec<f64> {
    let n = iterations.len();
    let mut weights = vec![0.0; n];
    if n == 0 {
        return weights;
    }
    let pooled = pooled_image(iterations);
    let variances = relative_variances(iterations, &pooled);
    // Inefficiency: relative variance × cost. Unknown (no halves, or zero) counts as the worst known.
    let known: Vec<Option<f64>> = variances
        .iter()
        .zip(cost)
        .map(|(v, &t)| {
            v.map(|v| v * t.max(1e-9))
                .filter(|e| *e > 0.0 && e.is_finite())
        })
        .collect();
    let worst = known.iter().flatten().cloned().fold(0.0f64, f64::max);
    if !(worst > 0.0) {
        // No iteration has a variance estimate: weight them by their cost.
        let total: f64 = cost.iter().map(|t| t.max(0.0)).sum();
        if total > 0.0 {
            for (w, t) in weights.iter_mut().zip(cost) {
                *w = t.max(0.0) / total;
            }
        } else {
            weights[n - 1] = 1.0;
        }
        return weights;
    }
    let last = known[n - 1].unwrap_or(worst);
    let raised: Vec<f64> = known.iter().map(|e| e.unwrap_or(worst).max(last)).collect();
    for i in 0..n {
        if raised[i] <= MAX_RELATIVE_INEFFICIENCY * last {
            weights[i] = cost[i].max(1e-9) / raised[i];
        }
    }
    let total: f64 = weights.iter().sum();
    weights.iter_mut().for_each(|w| *w /= total);
    weights
}

/// The sample-count weighted mean of all iterations (unbiased; the denominator of the relative variance).
pub fn pooled_image(iterations: &[IterationImage]) -> Image {
    let total: f64 = iterations
        .iter()
        .map(|i| i.spp() as f64)
        .sum::<f64>()
        .max(1.0);
    let mut out = iterations[0].image();
    out.scale(iterations[0].spp() as f64 / total);
    for it in &iterations[1..] {
        out.add_scaled(&it.image(), it.spp() as f64 / total);
    }
    out
}

/// Σ w_i I_i for weights that sum to 1 (iterations of weight 0 are skipped).
pub fn weighted_image(iterations: &[IterationImage], weights: &[f64]) -> Image {
    let mut out: Option<Image> = None;
    for (it, &w) in iterations.iter().zip(weights) {
        if w == 0.0 {
            continue;
        }
        match &mut out {
            None => {
                let mut img = it.image();
                img.scale(w);
                out = Some(img);
            }
            Some(o) => o.add_scaled(&it.image(), w),
        }
    }
    out.unwrap_or_else(|| iterations.last().expect("at least one iteration").image())
}

#[cfg(test)]
mod tests {
    use super::*;
    use focal_testkit::TestRng;

    const SIDE: u32 = 64;

    /// An iteration of `spp` samples (two equal halves) of an image that is `background` everywhere and
    /// `feature` in the top-left 8x8 pixels, with per-sample noise of relative standard deviation `sigma`.
    fn iteration(
        rng: &mut TestRng,
        spp: u32,
        background: f64,
        feature: f64,
        sigma: f64,
    ) -> IterationImage {
        let half = |rng: &mut TestRng| {
            let mut img = Image::new(SIDE, SIDE);
            let s = sigma / ((spp / 2) as f64).sqrt();
            for y in 0..SIDE {
                for x in 0..SIDE {
                    let v = if x < 8 && y < 8 { feature } else { background };
                    let noisy = (v * (1.0 + s * rng.next_normal())).max(0.0) as f32;
                    img.rgb[(y * SIDE + x) as usize] = [noisy; 3];
                }
            }
            img
        };
        IterationImage {
            a: (half(rng), spp / 2),
            b: (half(rng), spp / 2),
        }
    }

    fn feature_level(image: &Image) -> f64 {
        let mut sum = 0.0;
        for y in 0..8 {
            for x in 0..8 {
                sum += image.rgb[(y * SIDE + x) as usize][0] as f64;
            }
        }
        sum / 64.0
    }

    #[test]
    fn iterations_that_missed_a_bright_feature_do_not_take_the_weight_of_those_that_found_it() {
        // Four iterations of one second each. The first two missed a small feature 40x brighter than
        // the rest (their samples never reached it, so they are quiet there); the last two found it,
        // with the noise of a rare bright path. Each is an unbiased estimate; the truth has the feature.
        let mut rng = TestRng::new(17);
        let its = vec![
            iteration(&mut rng, 8, 0.5, 0.5, 0.3),
            iteration(&mut rng, 8, 0.5, 0.5, 0.3),
            iteration(&mut rng, 8, 0.5, 20.0, 2.0),
            iteration(&mut rng, 8, 0.5, 20.0, 2.0),
        ];
        let seconds = [1.0; 4];
        let w = robust_inverse_variance_weights(&its, &seconds);
        let combined = weighted_image(&its, &w);
        // Nothing weighs more than its share of the time next to the later iterations: the feature keeps
        // at least the finders' share, 1/2 of its level (the time-weighted, unbiased combination).
        assert!(feature_level(&combined) >= 0.5 * 20.0 * 0.95, "{w:?}");
        // Plain inverse-variance weights, from the same estimates, hand the weight to the quiet ones.
        let pooled = pooled_image(&its);
        let inverse: Vec<f64> = relative_variances(&its, &pooled)
            .into_iter()
            .map(|v| 1.0 / v.unwrap())
            .collect();
        let total: f64 = inverse.iter().sum();
        let naive: Vec<f64> = inverse.iter().map(|w| w / total).collect();
        assert!(
            feature_level(&weighted_image(&its, &naive)) < 0.2 * 20.0,
            "{naive:?}"
        );
    }

    #[test]
    fn a_guide_that_improves_keeps_the_inverse_variance_weights() {
        // Per-sample noise halving from one iteration to the next at equal time: each later one is
        // better, so the raise changes nothing and the weights follow 1/v (about 1 : 4 : 16).
        let mut rng = TestRng::new(3);
        let its = vec![
            iteration(&mut rng, 16, 0.5, 0.5, 0.8),
            iteration(&mut rng, 16, 0.5, 0.5, 0.4),
            iteration(&mut rng, 16, 0.5, 0.5, 0.2),
        ];
        let w = robust_inverse_variance_weights(&its, &[1.0; 3]);
        assert!((w[1] / w[0] - 4.0).abs() < 0.6, "{w:?}");
        assert!((w[2] / w[1] - 4.0).abs() < 0.6, "{w:?}");
    }

    #[test]
    fn a_far_worse_iteration_is_left_out() {
        let mut rng = TestRng::new(5);
        let its = vec![
            iteration(&mut rng, 16, 0.5, 0.5, 2.0),
            iteration(&mut rng, 16, 0.5, 0.5, 0.2),
        ];
        // 100 times the variance at equal time: beyond MAX_RELATIVE_INEFFICIENCY.
        let w = robust_inverse_variance_weights(&its, &[1.0, 1.0]);
        assert_eq!(w[0], 0.0);
        assert_eq!(w[1], 1.0);
    }

    #[test]
    fn without_variance_estimates_the_weights_follow_the_render_time() {
        // Black images (nothing found yet) and a one-sample iteration have no estimate.
        let black = |spp: u32| IterationImage {
            a: (Image::new(SIDE, SIDE), spp / 2),
            b: (Image::new(SIDE, SIDE), spp - spp / 2),
        };
        let w = robust_inverse_variance_weights(&[black(4), black(4), black(1)], &[1.0, 1.0, 2.0]);
        assert_eq!(w, vec![0.25, 0.25, 0.5]);
        // A black final iteration next to one that found light counts as the least efficient, so the
        // earlier one cannot be raised above it and keeps its time share.
        let mut rng = TestRng::new(7);
        let lit = iteration(&mut rng, 4, 0.5, 0.5, 0.5);
        let w = robust_inverse_variance_weights(&[lit, black(4)], &[1.0, 1.0]);
        assert_eq!(w, vec![0.5, 0.5]);
    }
}
