//! The benchmark's score: an image that missed the light cannot win it.
//!
//! A render of a room lit through a small opening often misses the rare paths that carry most of the
//! light: its image is too dark, and quiet. relMSE with an absolute ε, trimmed of its largest per-pixel
//! errors, rewards such an image (it is close to a black image, which has no fireflies to trim), and
//! so do medians over seeds. This score judges in two steps:
//!
//! 1. **Bias first.** The image's mean brightness with its brightest [`TRIM_FRACTION`] of pixels left out,
//!    over the truth's (likewise trimmed), must be within [`FAILURE_TOLERANCE`] of 1. A black image, or
//!    one whose brightness is all in a few fireflies, *fails*, whatever its relMSE.
//! 2. **Then the expected error**: relMSE over all pixels (untrimmed), with the exposure normalised: ε is
//!    [`RELATIVE_EPSILON`] times the truth's squared mean brightness, so the score does not depend on
//!    the scene's units and a dim room is not judged by the noise of its darkest pixels. Against two
//!    independent references it estimates the error against the true image (see [`crate::eval::two_reference`]).
//!
//! With this normalisation a black image scores mean t²/(t² + ε) < 1 ([`Score::black_rel_mse`]), so a
//! relMSE near or above that level says the budget was too small for the score to mean anything.

use crate::eval::metrics::{finite, trimmed_mean};
use crate::film::Image;

/// The share of brightest pixels the bias check leaves out (the literature's 0.1 % outliers).
pub const TRIM_FRACTION: f64 = 1e-3;
/// A run fails when its trimmed mean brightness is off the truth's by more than this share.
pub const FAILURE_TOLERANCE: f64 = 0.3;
/// ε of the exposure-normalised relMSE, relative to the truth's squared mean brightness.
pub const RELATIVE_EPSILON: f64 = 1e-2;

/// How one image scores against the truth.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Score {
    /// The truth's mean brightness (mean over pixels of the channels' mean): the exposure unit.
    pub truth_brightness: f64,
    /// Exposure-normalised relMSE over all pixels (against the true image when two references were
    /// given, else against the one reference).
    pub rel_mse: f64,
    /// What a black image scores by the same estimator.
    pub black_rel_mse: f64,
    /// The image's mean brightness over the truth's.
    pub mean_ratio: f64,
    /// The same with each image's brightest [`TRIM_FRACTION`] of pixels left out.
    pub trimmed_mean_ratio: f64,
    /// The trimmed mean ratio is off 1 by more than [`FAILURE_TOLERANCE`]: black, or fireflies only.
    pub failed: bool,
}

impl Score {
    /// The relMSE is at least half of a black image's: at this budget the score says little.
    pub fn scores_like_black(&self) -> bool {
        self.rel_mse >= 0.5 * self.black_rel_mse
    }
}

fn brightness(p: &[f32; 3]) -> f64 {
    (finite(p[0]) + finite(p[1]) + finite(p[2])) / 3.0
}

/// Mean brightness of `image` after leaving out its `fraction` brightest pixels.
pub fn trimmed_brightness(image: &Image, fraction: f64) -> f64 {
    let values: Vec<f64> = image.rgb.iter().map(brightness).collect();
    trimmed_mean(&values, fraction)
}

fn same_size(image: &Image, reference: &Image, what: &str) -> Result<(), String> {
    if image.width != reference.width || image.height != reference.height {
        return Err(format!(
            "the image is {}x{} but the {what} is {}x{}",
            image.width, image.height, reference.width, reference.height
        ));
    }
    Ok(())
}

/// Scores `image` against the reference `a`, or against the truth estimated from the independent
/// references `a` and `b`.
pub fn score(image: &Image, a: &Image, b: Option<&Image>) -> Result<Score, String> {
    same_size(image, a, "reference")?;
    if let Some(b) = b {
        same_size(image, b, "second reference")?;
    }
    let truth: Vec<[f64; 3]> = match b {
        Some(b) => a
            .rgb
            .iter()
            .zip(&b.rgb)
            .map(|(a, b)| std::array::from_fn(|c| 0.5 * (finite(a[c]) + finite(b[c]))))
            .collect(),
        None => a
            .rgb
            .iter()
            .map(|a| std::array::from_fn(|c| finite(a[c])))
            .collect(),
    };
    let pixels = truth.len().max(1) as f64;
    let truth_brightness = truth
        .iter()
        .map(|t| (t[0] + t[1] + t[2]) / 3.0)
        .sum::<f64>()
        / pixels;
    let epsilon = if truth_brightness > 0.0 {
        RELATIVE_EPSILON * truth_brightness * truth_brightness
    } else {
        RELATIVE_EPSILON
    };
    let (mut rel, mut black) = (0.0f64, 0.0f64);
    for (p, t) in truth.iter().enumerate() {
        let x = image.rgb[p];
        for c in 0..3 {
            let norm = t[c] * t[c] + epsilon;
            let x = finite(x[c]);
            match b {
                Some(b) => {
                    let (ra, rb) = (finite(a.rgb[p][c]), finite(b.rgb[p][c]));
                    rel += (x - ra) * (x - rb) / norm;
                    black += ra * rb / norm;
                }
                None => {
                    rel += (x - t[c]) * (x - t[c]) / norm;
                    black += t[c] * t[c] / norm;
                }
            }
        }
    }
    let rel_mse = rel / (3.0 * pixels);
    let black_rel_mse = black / (3.0 * pixels);
    let image_brightness = image.rgb.iter().map(brightness).sum::<f64>() / pixels;
    let truth_values: Vec<f64> = truth.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
    let truth_trimmed = trimmed_mean(&truth_values, TRIM_FRACTION);
    let ratio = |x: f64, t: f64| {
        if t > 0.0 {
            x / t
        } else if x > 0.0 {
            f64::INFINITY
        } else {
            1.0
        }
    };
    let trimmed_mean_ratio = ratio(trimmed_brightness(image, TRIM_FRACTION), truth_trimmed);
    Ok(Score {
        truth_brightness,
        rel_mse,
        black_rel_mse,
        mean_ratio: ratio(image_brightness, truth_brightness),
        trimmed_mean_ratio,
        failed: !((trimmed_mean_ratio - 1.0).abs() <= FAILURE_TOLERANCE),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use focal_testkit::TestRng;

    const SIDE: u32 = 64;

    /// A smooth "truth": a gradient with a bright corner, in arbitrary units.
    fn truth(scale: f32) -> Image {
        let mut img = Image::new(SIDE, SIDE);
        for y in 0..SIDE {
            for x in 0..SIDE {
                let v = 0.05
                    + (x + y) as f32 / (2 * SIDE) as f32
                    + if x < 8 && y < 8 { 5.0 } else { 0.0 };
                img.rgb[(y * SIDE + x) as usize] = [v * scale, 0.8 * v * scale, 0.6 * v * scale];
            }
        }
        img
    }

    fn noisy(truth: &Image, sigma: f32, rng: &mut TestRng) -> Image {
        let mut img = truth.clone();
        for p in &mut img.rgb {
            for c in p.iter_mut() {
                *c *= 1.0 + sigma * rng.next_normal() as f32;
            }
        }
        img
    }

    #[test]
    fn a_black_image_fails_and_scores_the_black_level() {
        let t = truth(1.0);
        let black = Image::new(SIDE, SIDE);
        let s = score(&black, &t, None).unwrap();
        assert!(s.failed);
        assert_eq!(s.trimmed_mean_ratio, 0.0);
        assert!((s.rel_mse - s.black_rel_mse).abs() < 1e-12);
        assert!(s.black_rel_mse > 0.5 && s.black_rel_mse < 1.0, "{s:?}");
        assert!(s.scores_like_black());
    }

    #[test]
    fn the_score_does_not_depend_on_the_scenes_units() {
        let mut rng = TestRng::new(5);
        let t = truth(1.0);
        let x = noisy(&t, 0.2, &mut rng);
        let s1 = score(&x, &t, None).unwrap();
        let scale = |img: &Image, k: f32| {
            let mut o = img.clone();
            o.rgb
                .iter_mut()
                .for_each(|p| p.iter_mut().for_each(|c| *c *= k));
            o
        };
        let s2 = score(&scale(&x, 1e-3), &scale(&t, 1e-3), None).unwrap();
        assert!(
            (s1.rel_mse / s2.rel_mse - 1.0).abs() < 1e-4,
            "{s1:?} {s2:?}"
        );
        assert!((s1.black_rel_mse / s2.black_rel_mse - 1.0).abs() < 1e-4);
        assert!(!s1.failed && !s1.scores_like_black(), "{s1:?}");
        // 20 % noise per channel: a relMSE near 0.04 where ε is negligible.
        assert!(s1.rel_mse > 0.02 && s1.rel_mse < 0.05, "{s1:?}");
    }

    #[test]
    fn an_image_whose_light_is_all_in_fireflies_fails() {
        // The right mean, but carried by 0.05 % of the pixels: trimming them leaves an image that is
        // too dark, which the bias check catches however good its untrimmed mean looks.
        let t = truth(1.0);
        let mut x = Image::new(SIDE, SIDE);
        let total: f64 = t.rgb.iter().map(brightness).sum();
        x.rgb[100] = [(total / 2.0) as f32; 3];
        x.rgb[2000] = [(total / 2.0) as f32; 3];
        let s = score(&x, &t, None).unwrap();
        assert!((s.mean_ratio - 1.0).abs() < 1e-4, "{s:?}");
        assert!(s.failed, "{s:?}");
    }

    #[test]
    fn two_references_take_their_noise_out_of_the_score_and_the_black_level() {
        let mut rng = TestRng::new(9);
        let t = truth(1.0);
        let x = noisy(&t, 0.1, &mut rng);
        let a = noisy(&t, 0.15, &mut rng);
        let b = noisy(&t, 0.15, &mut rng);
        let exact = score(&x, &t, None).unwrap();
        let one = score(&x, &a, None).unwrap();
        let two = score(&x, &a, Some(&b)).unwrap();
        // Against one noisy reference the reference's 0.0225 adds to the image's 0.01; two references
        // leave about 1.5 σ⁴ of theirs (σ = 0.15: 0.0008).
        assert!(one.rel_mse > 2.5 * exact.rel_mse, "{one:?} {exact:?}");
        assert!(
            (two.rel_mse / exact.rel_mse - 1.0).abs() < 0.25,
            "{two:?} {exact:?}"
        );
        assert!(
            (two.black_rel_mse / exact.black_rel_mse - 1.0).abs() < 0.1,
            "{two:?} {exact:?}"
        );
        assert!(!two.failed);
    }

    #[test]
    fn sizes_must_match() {
        let t = truth(1.0);
        assert!(score(&Image::new(3, 3), &t, None).is_err());
        assert!(score(&t, &t, Some(&Image::new(3, 3))).is_err());
    }
}
