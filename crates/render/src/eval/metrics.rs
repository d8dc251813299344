//! Image error metrics for comparing renders against a reference.
//!
//! All metrics are averaged over pixels and RGB channels. relMSE divides each squared error by
//! (reference² + ε) so dark pixels do not dominate, as in the path-guiding literature (ε = 1e-2 unless
//! stated). Outlier rejection, when asked for, drops the given fraction of the largest per-pixel errors
//! of each metric before averaging (the literature's "0.1 % outliers removed").

use crate::film::Image;

/// The ε of relMSE used throughout the project unless stated.
pub const DEFAULT_REL_EPSILON: f64 = 1e-2;

/// The share of pixels whose part of the relMSE [`ImageErrors::rel_mse_top_share`] reports (the
/// literature's 0.1 % outliers): when it holds most of the error, the error is a few fireflies, and
/// one render says little about another with a different seed.
pub const FIREFLY_PIXEL_FRACTION: f64 = 1e-3;

/// Errors of an image against a reference.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImageErrors {
    /// Mean of (x − r)² / (r² + ε).
    pub rel_mse: f64,
    /// Mean of (x − r)².
    pub mse: f64,
    /// Mean of |x − r| / (|r| + ε).
    pub mape: f64,
    /// Mean of 2|x − r| / (|x| + |r| + ε) (0 where both are 0).
    pub smape: f64,
    /// The ε used.
    pub epsilon: f64,
    /// The fraction of the largest per-pixel errors dropped before averaging.
    pub outlier_fraction: f64,
    /// relMSE over all pixels (equal to `rel_mse` when no outliers are dropped).
    pub rel_mse_all: f64,
    /// The share of the all-pixel relMSE held by the [`FIREFLY_PIXEL_FRACTION`] largest per-pixel
    /// errors (at least one pixel).
    pub rel_mse_top_share: f64,
}

/// Per-pixel errors (averaged over the channels) of `image` against `reference`.
pub fn per_pixel_errors(
    image: &Image,
    reference: &Image,
    epsilon: f64,
) -> Result<[Vec<f64>; 4], String> {
    if image.width != reference.width || image.height != reference.height {
        return Err(format!(
            "images differ in size: {}x{} and {}x{}",
            image.width, image.height, reference.width, reference.height
        ));
    }
    let n = image.rgb.len();
    let mut out = [
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    ];
    for (x, r) in image.rgb.iter().zip(&reference.rgb) {
        let (mut rel, mut se, mut ape, mut sape) = (0.0, 0.0, 0.0, 0.0);
        for c in 0..3 {
            let (x, r) = (finite(x[c]), finite(r[c]));
            let d = x - r;
            rel += d * d / (r * r + epsilon);
            se += d * d;
            ape += d.abs() / (r.abs() + epsilon);
            let denom = x.abs() + r.abs() + epsilon;
            sape += if denom > 0.0 {
                2.0 * d.abs() / denom
            } else {
                0.0
            };
        }
        out[0].push(rel / 3.0);
        out[1].push(se / 3.0);
        out[2].push(ape / 3.0);
        out[3].push(sape / 3.0);
    }
    Ok(out)
}

/// A non-finite value counts as 0 (images written by focal never hold one; others might).
pub(crate) fn finite(v: f32) -> f64 {
    if v.is_finite() {
        v as f64
    } else {
        0.0
    }
}

/// How many of `len` values make the `fraction` largest (rounded down).
fn largest_count(len: usize, fraction: f64) -> usize {
    ((len as f64) * fraction.clamp(0.0, 1.0)).floor() as usize
}

/// The mean of `values` after dropping the `fraction` largest.
pub fn trimmed_mean(values: &[f64], fraction: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let drop = largest_count(values.len(), fraction);
    let keep = values.len() - drop.min(values.len() - 1);
    if drop == 0 {
        return values.iter().sum::<f64>() / values.len() as f64;
    }
    let mut v = values.to_vec();
    v.select_nth_unstable_by(keep - 1, |a, b| a.total_cmp(b));
    v[..keep].iter().sum::<f64>() / keep as f64
}

/// The share of the sum of non-negative `values` held by the `fraction` largest (at least one); 0 when
/// the sum is 0.
pub fn top_share(values: &[f64], fraction: f64) -> f64 {
    let total: f64 = values.iter().sum();
    if values.is_empty() || !(total > 0.0) {
        return 0.0;
    }
    // As many as `trimmed_mean` drops, so that the share tells how much trimming removed.
    let count = largest_count(values.len(), fraction).clamp(1, values.len());
    let mut v = values.to_vec();
    let split = values.len() - count;
    v.select_nth_unstable_by(split, |a, b| a.total_cmp(b));
    v[split..].iter().sum::<f64>() / total
}

/// All metrics of `image` against `reference`.
pub fn image_errors(
    image: &Image,
    reference: &Image,
    epsilon: f64,
    outlier_fraction: f64,
) -> Result<ImageErrors, String> {
    let [rel, se, ape, sape] = per_pixel_errors(image, reference, epsilon)?;
    Ok(ImageErrors {
        rel_mse: trimmed_mean(&rel, outlier_fraction),
        mse: trimmed_mean(&se, outlier_fraction),
        mape: trimmed_mean(&ape, outlier_fraction),
        smape: trimmed_mean(&sape, outlier_fraction),
        epsilon,
        outlier_fraction,
        rel_mse_all: trimmed_mean(&rel, 0.0),
        rel_mse_top_share: top_share(&rel, FIREFLY_PIXEL_FRACTION),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[[f32; 3]]) -> Image {
        let mut img = Image::new(values.len() as u32, 1);
        img.rgb.copy_from_slice(values);
        img
    }

    #[test]
    fn top_share_tells_fireflies_from_even_noise() {
        let even = vec![1.0; 10_000];
        assert!((top_share(&even, 1e-3) - 1e-3).abs() < 1e-12);
        let mut firefly = vec![1e-4; 10_000];
        firefly[4321] = 100.0;
        assert!(top_share(&firefly, 1e-3) > 0.99);
        // At least one value counts; an all-zero error has no share.
        assert_eq!(top_share(&[0.0, 3.0], 0.0), 1.0);
        assert_eq!(top_share(&[0.0, 0.0], 1e-3), 0.0);
        assert_eq!(top_share(&[], 1e-3), 0.0);
        // The image metrics carry the all-pixel relMSE and its share next to the trimmed one.
        let r = image(&[[1.0; 3]; 4]);
        let x = image(&[[1.0; 3], [1.0; 3], [1.0; 3], [3.0; 3]]);
        let e = image_errors(&x, &r, 0.0, 0.25).unwrap();
        assert_eq!(e.rel_mse, 0.0);
        assert!((e.rel_mse_all - 1.0).abs() < 1e-12, "{e:?}");
        assert_eq!(e.rel_mse_top_share, 1.0);
    }

    #[test]
    fn metrics_match_hand_computed_values() {
        let r = image(&[[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]);
        let x = image(&[[2.0, 1.0, 1.0], [0.1, 0.1, 0.1]]);
        let e = image_errors(&x, &r, 0.01, 0.0).unwrap();
        // Pixel 0: one channel off by 1: rel = 1/(1.01)/3; pixel 1: 0.01/0.01 = 1 per channel.
        let rel0 = 1.0 / 1.01 / 3.0;
        assert!((e.rel_mse - (rel0 + 1.0) / 2.0).abs() < 1e-6, "{e:?}");
        assert!((e.mse - (1.0 / 3.0 + 0.01) / 2.0).abs() < 1e-6);
        let mape0 = 1.0 / 1.01 / 3.0;
        let mape1 = 0.1 / 0.01;
        assert!((e.mape - (mape0 + mape1) / 2.0).abs() < 1e-5);
        let smape0 = 2.0 / 3.01 / 3.0;
        let smape1 = 2.0 * 0.1 / 0.11;
        assert!((e.smape - (smape0 + smape1) / 2.0).abs() < 1e-5);
        // Rejecting half the pixels keeps the smaller error only.
        let t = image_errors(&x, &r, 0.01, 0.5).unwrap();
        assert!((t.rel_mse - rel0).abs() < 1e-6);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = Image::new(2, 2);
        let b = Image::new(3, 2);
        assert!(image_errors(&a, &b, 0.01, 0.0).is_err());
    }
}
