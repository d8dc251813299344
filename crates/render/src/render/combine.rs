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

/// Radius (pixels) of the box filter that smooths the denominator of
/// [`robust_per_sample_relative_variance`].
pub const ROBUST_DENOMINATOR_RADIUS: usize = 4;
/// Share of the largest per-pixel terms [`robust_per_sample_relative_variance`] drops (as the
/// benchmark's relMSE drops its 0.1 % largest per-pixel errors).
pub const ROBUST_TRIM: f64 = 1e-3;

/// The per-pixel channel mean of `image` box-filtered over a (2r + 1)² window (clamped at the borders).
pub fn smoothed_luminance(image: &Image, radius: usize) -> Vec<f64> {
    let (w, h) = (image.width as usize, image.height as usize);
    let mean: Vec<f64> = image
        .rgb
        .iter()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .collect();
    let blur = |src: &[f64], stride: usize, len: usize, lines: usize, step: usize| {
        let mut out = vec![0.0; src.len()];
        for line in 0..lines {
            let at = |i: usize| src[line * step + i * stride];
            for i in 0..len {
                let lo = i.saturating_sub(radius);
                let hi = (i + radius).min(len - 1);
                let s: f64 = (lo..=hi).map(at).sum();
                out[line * step + i * stride] = s / (hi - lo + 1) as f64;
            }
        }
        out
    };
    if w == 0 || h == 0 {
        return mean;
    }
    let rows = blur(&mean, 1, w, h, w);
    blur(&rows, w, h, w, 1)
}

/// The relative per-sample variance σ² of an estimator from two independent images of it, as
/// [`per_sample_relative_variance`] but robust to the self-normalisation that hides rare large
/// samples: each pixel's squared difference is divided by `denominator`² + ε with a *smoothed* mean
/// ([`smoothed_luminance`]; a pooled pixel holding a firefly F over n samples would otherwise cap its
/// own relative variance at about n), and the [`ROBUST_TRIM`] largest terms are dropped.
pub fn robust_per_sample_relative_variance(
    a: &Image,
    na: u32,
    b: &Image,
    nb: u32,
    denominator: &[f64],
) -> Option<f64> {
    if na == 0 || nb == 0 || a.rgb.len() != denominator.len() || b.rgb.len() != denominator.len() {
        return None;
    }
    let scale = 1.0 / (1.0 / na as f64 + 1.0 / nb as f64);
    let mut terms: Vec<f64> = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .zip(denominator)
        .map(|((pa, pb), m)| {
            let d2: f64 = (0..3)
                .map(|c| {
                    let d = pa[c] as f64 - pb[c] as f64;
                    d * d
                })
                .sum();
            d2 / 3.0 * scale / (m * m + RELATIVE_EPSILON)
        })
        .collect();
    let keep = terms.len() - (terms.len() as f64 * ROBUST_TRIM) as usize;
    if keep == 0 {
        return None;
    }
    terms.select_nth_unstable_by(keep - 1, f64::total_cmp);
    let v = terms[..keep].iter().sum::<f64>() / keep as f64;
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constant(w: u32, h: u32, v: f32) -> Image {
        let mut img = Image::new(w, h);
        img.rgb.iter_mut().for_each(|p| *p = [v; 3]);
        img
    }

    #[test]
    fn smoothing_keeps_constants_and_spreads_a_spike_over_its_window() {
        let flat = smoothed_luminance(&constant(7, 5, 2.0), 2);
        assert!(flat.iter().all(|v| (v - 2.0).abs() < 1e-12));
        let mut spike = constant(20, 20, 0.0);
        spike.rgb[10 * 20 + 10] = [81.0; 3];
        let s = smoothed_luminance(&spike, 4);
        // Away from the borders the spike is spread evenly over the 9×9 windows containing it.
        assert!((s[10 * 20 + 10] - 1.0).abs() < 1e-12);
        assert!((s[6 * 20 + 14] - 1.0).abs() < 1e-12);
        assert_eq!(s[5 * 20 + 10], 0.0);
        assert!((s.iter().sum::<f64>() - 81.0).abs() < 1e-9);
    }

    #[test]
    fn a_firefly_counts_fully_against_a_smoothed_denominator() {
        let (w, h) = (16, 16);
        let b = constant(w, h, 1.0);
        let mut a = b.clone();
        let spike = 8 * 16 + 8;
        let d = 100.0f64;
        a.rgb[spike] = [(1.0 + d) as f32; 3];
        let mut pooled = a.clone();
        pooled.scale(0.5);
        pooled.add_scaled(&b, 0.5);
        // Self-normalised: the firefly's own pixel mean (1 + d/2) nearly cancels its variance.
        let naive = per_sample_relative_variance(&a, 1, &b, 1, &pooled).unwrap();
        let naive_hand = d * d * 0.5 / ((1.0 + d / 2.0).powi(2) + RELATIVE_EPSILON) / 256.0;
        assert!((naive - naive_hand).abs() < 1e-9 * naive_hand);
        // Smoothed: the denominator is the 9×9 mean, 1 + (d/2)/81 (256 pixels: nothing trimmed).
        let den = smoothed_luminance(&pooled, ROBUST_DENOMINATOR_RADIUS);
        let robust = robust_per_sample_relative_variance(&a, 1, &b, 1, &den).unwrap();
        let m = 1.0 + d / 2.0 / 81.0;
        let robust_hand = d * d * 0.5 / (m * m + RELATIVE_EPSILON) / 256.0;
        assert!(
            (robust - robust_hand).abs() < 1e-9 * robust_hand,
            "{robust} {robust_hand}"
        );
        assert!(robust > 500.0 * naive);
    }

    #[test]
    fn trimming_drops_the_largest_terms() {
        // 2000 pixels: the two largest terms (0.1 %) are dropped, so two fireflies leave no trace.
        let b = constant(100, 20, 1.0);
        let mut a = b.clone();
        a.rgb[5] = [50.0; 3];
        a.rgb[1999] = [70.0; 3];
        let den = vec![1.0; 2000];
        assert_eq!(
            robust_per_sample_relative_variance(&a, 1, &b, 1, &den),
            Some(0.0)
        );
        a.rgb[7] = [2.0; 3];
        let v = robust_per_sample_relative_variance(&a, 1, &b, 1, &den).unwrap();
        let hand = 0.5 / (1.0 + RELATIVE_EPSILON) / 1998.0;
        assert!((v - hand).abs() < 1e-12, "{v} {hand}");
    }
}
