//! relMSE against the true image, estimated from two noisy references.
//!
//! Against one reference r, relMSE measures E[(x − r)²] = Var x + bias² + Var r per pixel: the
//! reference's own noise adds the same amount to every method's error and pulls their ratios towards 1.
//! Focal scenes make that floor high. A two-minute guided reference of a pinhole or a lens focus can
//! hold as much error as a ten-second render (docs/experiments/2026-12-03-benchmark-references.md), and
//! Mitsuba 3's 16384 spp camera obscura is still noisy.
//!
//! Given two references a and b, independent of the image x and of each other, and each unbiased,
//!
//!   E[(x − a)(x − b)] = E[(x − μ)²],
//!
//! the image's own mean squared error against the true μ: the cross terms of the references' errors
//! vanish. This is the "three-cornered hat" of clock metrology. Per pixel it can be negative; over an
//! image it estimates the error the image would show against a perfect reference. Each term is divided
//! by (m² + ε), with m = (a + b)/2, as relMSE divides by r² + ε. The denominator is itself estimated and
//! correlates with the references' errors, so a small bias remains: about 1.5 σ_r⁴ per pixel for
//! references of relative noise σ_r each (and ε small), where one reference adds σ_r². References as
//! noisy as 20 % per pixel thus leave 6 % of their noise in the estimate instead of all of it.

use crate::eval::metrics::{finite, trimmed_mean};
use crate::film::Image;

/// Per-pixel estimates (averaged over the channels) of (x − μ)²/(μ² + ε) for `image` from the independent
/// references `a` and `b`: (x − a)(x − b)/(m² + ε) with m = (a + b)/2. Non-finite values count as 0.
pub fn per_pixel_two_reference_errors(
    image: &Image,
    a: &Image,
    b: &Image,
    epsilon: f64,
) -> Result<Vec<f64>, String> {
    for (name, r) in [("first", a), ("second", b)] {
        if image.width != r.width || image.height != r.height {
            return Err(format!(
                "the image is {}x{} but the {name} reference is {}x{}",
                image.width, image.height, r.width, r.height
            ));
        }
    }
    Ok(image
        .rgb
        .iter()
        .zip(&a.rgb)
        .zip(&b.rgb)
        .map(|((x, a), b)| {
            (0..3)
                .map(|c| {
                    let (x, a, b) = (finite(x[c]), finite(a[c]), finite(b[c]));
                    let m = 0.5 * (a + b);
                    (x - a) * (x - b) / (m * m + epsilon)
                })
                .sum::<f64>()
                / 3.0
        })
        .collect())
}

/// The relMSE of `image` against the true image, estimated from the independent references `a` and
/// `b` (see the module notes), after dropping the `outlier_fraction` largest per-pixel estimates.
pub fn two_reference_rel_mse(
    image: &Image,
    a: &Image,
    b: &Image,
    epsilon: f64,
    outlier_fraction: f64,
) -> Result<f64, String> {
    let per_pixel = per_pixel_two_reference_errors(image, a, b, epsilon)?;
    Ok(trimmed_mean(&per_pixel, outlier_fraction))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::metrics::image_errors;

    use focal_testkit::TestRng;

    /// `truth` with zero-mean uniform noise of relative standard deviation `sigma` on every channel.
    fn noisy(truth: &[f64], sigma: f64, rng: &mut TestRng) -> Image {
        let mut img = Image::new(truth.len() as u32, 1);
        for (p, t) in img.rgb.iter_mut().zip(truth) {
            for v in p.iter_mut() {
                *v = (t + (rng.next_f64() - 0.5) * 12f64.sqrt() * sigma * t) as f32;
            }
        }
        img
    }

    #[test]
    fn recovers_the_error_against_the_truth_from_noisy_references() {
        // Relative noise σ: the true relMSE is about σ² (ε small against the values).
        let truth: Vec<f64> = (0..200_000).map(|i| 1.0 + (i % 7) as f64).collect();
        let mut rng = TestRng::new(7);
        let (sx, sr) = (0.1, 0.1);
        let x = noisy(&truth, sx, &mut rng);
        let a = noisy(&truth, sr, &mut rng);
        let b = noisy(&truth, sr, &mut rng);
        let mut exact = Image::new(truth.len() as u32, 1);
        for (p, t) in exact.rgb.iter_mut().zip(&truth) {
            *p = [*t as f32; 3];
        }
        let eps = 1e-4;
        let against_truth = image_errors(&x, &exact, eps, 0.0).unwrap().rel_mse;
        let against_one = image_errors(&x, &a, eps, 0.0).unwrap().rel_mse;
        let estimate = two_reference_rel_mse(&x, &a, &b, eps, 0.0).unwrap();
        assert!(
            (against_truth - sx * sx).abs() < 0.02 * sx * sx,
            "{against_truth}"
        );
        // A reference as noisy as the image doubles its apparent error.
        assert!(
            against_one > 1.9 * against_truth,
            "{against_one} {against_truth}"
        );
        // The two-reference estimate finds the image's own error, within the denominator's bias
        // (1.5 σ_r⁴ = 1.5 % of σ_x² here) and the sampling noise of 600 000 products (about 1 %).
        assert!(
            (estimate / against_truth - 1.0).abs() < 0.05,
            "estimate {estimate}, against the truth {against_truth}"
        );
    }

    #[test]
    fn exact_references_give_plain_rel_mse_and_sizes_are_checked() {
        let mut r = Image::new(2, 1);
        r.rgb = vec![[1.0; 3], [2.0; 3]];
        let mut x = r.clone();
        x.rgb[1] = [3.0; 3];
        let plain = image_errors(&x, &r, 0.01, 0.0).unwrap().rel_mse;
        let two = two_reference_rel_mse(&x, &r, &r, 0.01, 0.0).unwrap();
        assert!((plain - two).abs() < 1e-12, "{plain} {two}");
        let small = Image::new(1, 1);
        assert!(two_reference_rel_mse(&x, &r, &small, 0.01, 0.0).is_err());
        assert!(two_reference_rel_mse(&small, &r, &r, 0.01, 0.0).is_err());
    }
}
