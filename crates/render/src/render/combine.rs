//! Combining the images of a guided render's iterations into one estimate.
//!
//! Every iteration's image is an unbiased estimate of the same image, rendered with a different (better
//! and better) guide. Rath et al. keep only the last one; Müller et al.'s later practice weights each
//! iteration by the inverse of its variance. We estimate an iteration's variance from the difference of
//! its two interleaved halves (even and odd sample indices), relative to the pooled image as relMSE does,
//! so bright pixels do not dominate:
//!
//!   v_i = mean_p [ mean_c (A_p − B_p)² · n_A n_B / n_i² ] / (pooled_p² + ε),   ε = 1e-2,
//!
//! which is the expected relative squared error of iteration i. Iterations with fewer than two samples per
//! pixel have no variance estimate and are left out, as are those with under [`MIN_RELATIVE_SPP`] of the
//! largest iteration's samples (heavy tails make their estimate too optimistic) and those whose weight
//! 1/v_i is below
//! [`MIN_RELATIVE_WEIGHT`] of the best (their guide was not good enough to matter); the result is
//! Σ w_i I_i / Σ w_i. The guided renderer leaves the unguided first iteration out whenever a guided one
//! exists: its noise is heavy-tailed (rare paths through a pinhole), which the estimate misses. The weights come from the same samples, so the combination is consistent rather
//! than exactly unbiased; `Combine::Last` is exactly unbiased.

use crate::film::Image;

/// Iterations whose inverse-variance weight is below this fraction of the largest are left out.
pub const MIN_RELATIVE_WEIGHT: f64 = 0.05;
/// Iterations with fewer samples per pixel than this fraction of the largest iteration's are left out:
/// with few samples the variance of heavy-tailed noise is underestimated (the rare bright path is
/// missing from both halves), which would give them far too much weight.
pub const MIN_RELATIVE_SPP: f64 = 0.25;
/// The ε of the relative variance (as in relMSE).
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
    iterations
        .iter()
        .map(|it| {
            per_sample_relative_variance(&it.a.0, it.a.1, &it.b.0, it.b.1, pooled)
                .map(|v| v / it.spp() as f64)
        })
        .collect()
}

/// The relative per-sample variance σ² of an estimator, from two independent images of it (`a` with
/// `na` samples per pixel, `b` with `nb`): Var(A − B) = σ²(1/na + 1/nb) per pixel and channel, each
/// pixel's divided by pooled² + ε, averaged over the image. `None` if either image has no samples.
pub fn per_sample_relative_variance(
    a: &Image,
    na: u32,
    b: &Image,
    nb: u32,
    pooled: &Image,
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
        sum += d2 / 3.0 * scale / (m * m + RELATIVE_EPSILON);
    }
    let v = sum / pooled.rgb.len().max(1) as f64;
    v.is_finite().then_some(v)
}

/// The inverse-variance weights (normalised to sum to 1; 0 for iterations left out). If no iteration has
/// a variance estimate, all weight goes to the last one.
pub fn inverse_variance_weights(iterations: &[IterationImage]) -> Vec<f64> {
    let mut weights = vec![0.0; iterations.len()];
    if iterations.is_empty() {
        return weights;
    }
    let pooled = pooled_image(iterations);
    let variances = relative_variances(iterations, &pooled);
    let max_spp = iterations
        .iter()
        .map(IterationImage::spp)
        .max()
        .unwrap_or(0) as f64;
    let variances: Vec<Option<f64>> = variances
        .into_iter()
        .zip(iterations)
        .map(|(v, it)| v.filter(|_| it.spp() as f64 >= MIN_RELATIVE_SPP * max_spp))
        .collect();
    for (w, v) in weights.iter_mut().zip(&variances) {
        *w = match v {
            Some(v) if *v > 0.0 => 1.0 / v,
            // A noiseless iteration (e.g. a black image) is as good as it gets.
            Some(_) => f64::MAX / iterations.len() as f64,
            None => 0.0,
        };
    }
    let best = weights.iter().cloned().fold(0.0, f64::max);
    if !(best > 0.0) {
        let mut w = vec![0.0; iterations.len()];
        *w.last_mut().unwrap() = 1.0;
        return w;
    }
    for w in &mut weights {
        if *w < MIN_RELATIVE_WEIGHT * best {
            *w = 0.0;
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
