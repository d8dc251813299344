//! Does guiding pay? An image-space comparison of the unguided first iteration with the guided ones.
//!
//! The unguided iteration's own two-halves variance misses what matters in a focal scene: with a few
//! samples per pixel the rare path through the pinhole is usually missing from both halves, so the
//! estimate says the path tracer is fine while its image is too dark. The guided iterations, which find
//! those paths, are an independent unbiased estimate of the same image, so the difference of the two
//! images sees the path tracer's actual error:
//!
//!   E[(U − G)²] = Var U + Var G   per pixel and channel (U unguided, G the pooled guided image),
//!
//! and Var G is known from the guided iterations' halves. The path tracer's relative error is therefore
//! estimated as mean_p [mean_c (U − G)² − Var G] / (G² + ε), ε = 1e-2 times G's squared mean brightness
//! (as the benchmark's exposure-normalised relMSE), where a missed caustic shows up in full. Each
//! estimator's inefficiency is its relative error times the time it took (relative error falls as
//! 1/time); guiding pays if its inefficiency is the smaller.
//!
//! Both estimates are means over pixels, and either can rest on a handful of them: a few fireflies (a
//! guided sample that found the bright path in a dim room, or an unguided one), or nothing at all when
//! neither image found any light. Such a comparison says nothing about which estimator is better, and
//! an image that missed the light would win it. Each estimate records the effective number of pixels it
//! rests on, (Σ e_p)² / Σ e_p² over its per-pixel terms e_p, as a share of the image
//! ([`CrossCheck::unguided_pixel_share`], [`CrossCheck::guided_pixel_share`]), for diagnosis only: the
//! Cornell box's unguided estimate rests on as few pixels as a firefly-ridden interior's, so the share
//! cannot gate the decision (docs/experiments/2026-12-07-decisions-missing-the-light.md). The fallback
//! instead waits for its first decisive check and for the guide's second-moment gain (render::guided).

use super::combine::{relative_epsilon, IterationImage};

/// The outcome of one comparison, for the JSON record.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CrossCheck {
    /// Estimated relative error of the unguided iteration's image (against the guided images).
    pub unguided_rel_error: f64,
    /// Its render time.
    pub unguided_s: f64,
    /// Estimated relative error of the pooled guided image (from each iteration's halves).
    pub guided_rel_error: f64,
    /// The guided iterations' render time.
    pub guided_s: f64,
    /// Guided over unguided inefficiency (relative error × time): below 1 where guiding pays.
    pub inefficiency_ratio: f64,
    /// The effective number of pixels the unguided error estimate rests on, as a share of the image (1
    /// where every pixel contributes alike, about 1/P where one pixel holds it all, 0 without any).
    pub unguided_pixel_share: f64,
    /// The same for the guided error estimate.
    pub guided_pixel_share: f64,
}

/// The effective number of terms a sum of `values` rests on, (Σ|v|)² / Σ v², as a share of their count
/// (0 when all are 0).
pub fn effective_share(values: &[f64]) -> f64 {
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for v in values {
        s1 += v.abs();
        s2 += v * v;
    }
    if s2 > 0.0 && s2.is_finite() {
        s1 * s1 / s2 / values.len() as f64
    } else {
        0.0
    }
}

/// Compares the unguided iteration `unguided` (render time `unguided_s`) with the guided iterations
/// `guided`, each with its render time. `None` if an image has no samples or a guided iteration has no
/// halves (fewer than two samples per pixel), or if the estimate is not finite.
pub fn cross_check(
    unguided: &IterationImage,
    unguided_s: f64,
    guided: &[(&IterationImage, f64)],
) -> Option<CrossCheck> {
    let total: u32 = guided.iter().map(|(it, _)| it.spp()).sum();
    if unguided.spp() == 0 || total == 0 {
        return None;
    }
    if guided.iter().any(|(it, _)| it.a.1 == 0 || it.b.1 == 0) {
        return None;
    }
    let u = unguided.image();
    // Per guided iteration: the weights of its halves in the pooled mean Σ_i (n_A·A + n_B·B)/N, and that
    // of its (A − B)² in the pooled variance: (n_i/N)² σ²/n_i with σ² = (A − B)² / (1/n_A + 1/n_B).
    let total = total as f64;
    let terms: Vec<(f64, f64, f64)> = guided
        .iter()
        .map(|(it, _)| {
            let (na, nb) = (it.a.1 as f64, it.b.1 as f64);
            let n = na + nb;
            let var = (n / total).powi(2) / (1.0 / na + 1.0 / nb) / n;
            (na / total, nb / total, var)
        })
        .collect();
    let pixels = u.rgb.len();
    // The pooled guided image's brightness sets ε (first pass), then the per-pixel terms (second pass).
    let mut pooled = crate::film::Image::new(u.width, u.height);
    for ((wa, wb, _), (it, _)) in terms.iter().zip(guided) {
        pooled.add_scaled(&it.a.0, *wa);
        pooled.add_scaled(&it.b.0, *wb);
    }
    let epsilon = relative_epsilon(&pooled);
    let (mut rel_u, mut rel_g) = (0.0f64, 0.0f64);
    let mut terms_u = Vec::with_capacity(pixels);
    let mut terms_g = Vec::with_capacity(pixels);
    for p in 0..pixels {
        let mut g = [0.0f64; 3];
        let mut var_g = 0.0f64;
        for ((wa, wb, var), (it, _)) in terms.iter().zip(guided) {
            let (a, b) = (it.a.0.rgb[p], it.b.0.rgb[p]);
            for c in 0..3 {
                let (a, b) = (a[c] as f64, b[c] as f64);
                g[c] += wa * a + wb * b;
                var_g += var * (a - b) * (a - b);
            }
        }
        let var_g = var_g / 3.0;
        let d2 = (0..3)
            .map(|c| (u.rgb[p][c] as f64 - g[c]).powi(2))
            .sum::<f64>()
            / 3.0;
        let m = (g[0] + g[1] + g[2]) / 3.0;
        let norm = m * m + epsilon;
        rel_u += (d2 - var_g) / norm;
        rel_g += var_g / norm;
        terms_u.push(d2 / norm);
        terms_g.push(var_g / norm);
    }
    let rel_u = (rel_u / pixels.max(1) as f64).max(0.0);
    let rel_g = rel_g / pixels.max(1) as f64;
    let guided_s: f64 = guided.iter().map(|(_, t)| t).sum();
    let ratio = (rel_g * guided_s) / (rel_u * unguided_s);
    let check = CrossCheck {
        unguided_rel_error: rel_u,
        unguided_s,
        guided_rel_error: rel_g,
        guided_s,
        inefficiency_ratio: if ratio.is_nan() { f64::INFINITY } else { ratio },
        unguided_pixel_share: effective_share(&terms_u),
        guided_pixel_share: effective_share(&terms_g),
    };
    (rel_u.is_finite() && rel_g.is_finite()).then_some(check)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Image;
    use crate::render::combine::RELATIVE_EPSILON;

    use focal_testkit::TestRng;

    const SIDE: u32 = 128;
    const MEAN: f64 = 0.5;

    /// An image of `MEAN` plus `offset` plus noise of standard deviation `sigma` in every channel.
    fn noisy(rng: &mut TestRng, offset: f64, sigma: f64) -> Image {
        let mut img = Image::new(SIDE, SIDE);
        for p in &mut img.rgb {
            for c in p.iter_mut() {
                *c = (MEAN + offset + sigma * rng.next_normal()) as f32;
            }
        }
        img
    }

    /// An iteration of `spp` samples of per-sample standard deviation `sigma`, as two equal halves.
    fn iteration(rng: &mut TestRng, spp: u32, sigma: f64) -> IterationImage {
        let half = spp / 2;
        let s = sigma / (half as f64).sqrt();
        IterationImage {
            a: (noisy(rng, 0.0, s), half),
            b: (noisy(rng, 0.0, s), spp - half),
        }
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a / b - 1.0).abs() < tol
    }

    #[test]
    fn recovers_both_estimators_relative_errors() {
        let mut rng = TestRng::new(7);
        let norm = MEAN * MEAN * (1.0 + RELATIVE_EPSILON);
        // Unguided: 8 spp of per-sample σ 0.4 in 1 s; guided: two iterations of 4 spp, σ 0.2, 1 s each.
        let u_sigma2 = 0.4f64 * 0.4 / 8.0;
        let unguided = IterationImage {
            a: (noisy(&mut rng, 0.0, u_sigma2.sqrt()), 8),
            b: (Image::new(0, 0), 0),
        };
        let g1 = iteration(&mut rng, 4, 0.2);
        let g2 = iteration(&mut rng, 4, 0.2);
        let c = cross_check(&unguided, 1.0, &[(&g1, 1.0), (&g2, 1.0)]).unwrap();
        let g_sigma2 = 0.2f64 * 0.2 / 8.0;
        assert!(close(c.unguided_rel_error, u_sigma2 / norm, 0.05), "{c:?}");
        assert!(close(c.guided_rel_error, g_sigma2 / norm, 0.05), "{c:?}");
        // Guided: a quarter of the variance at twice the time.
        assert!(close(c.inefficiency_ratio, 0.5, 0.08), "{c:?}");
        assert_eq!(c.guided_s, 2.0);
    }

    #[test]
    fn sees_what_the_unguided_halves_miss() {
        // The unguided image lacks a rare contribution everywhere (too dark by 0.1, its halves agree):
        // its error is that offset, found against the unbiased guided images.
        let mut rng = TestRng::new(11);
        let unguided = IterationImage {
            a: (noisy(&mut rng, -0.1, 0.0), 4),
            b: (noisy(&mut rng, -0.1, 0.0), 4),
        };
        let g = iteration(&mut rng, 8, 0.1);
        let c = cross_check(&unguided, 1.0, &[(&g, 1.0)]).unwrap();
        let norm = MEAN * MEAN * (1.0 + RELATIVE_EPSILON);
        assert!(close(c.unguided_rel_error, 0.01 / norm, 0.05), "{c:?}");
        // The guided variance 0.1²/8 against 0.1² at equal time.
        assert!(close(c.inefficiency_ratio, 0.125, 0.08), "{c:?}");
    }

    #[test]
    fn needs_samples_and_halves() {
        let mut rng = TestRng::new(3);
        let u = iteration(&mut rng, 4, 0.1);
        let g = iteration(&mut rng, 4, 0.1);
        let empty = IterationImage {
            a: (Image::new(SIDE, SIDE), 0),
            b: (Image::new(0, 0), 0),
        };
        let one_half = IterationImage {
            a: (noisy(&mut rng, 0.0, 0.1), 1),
            b: (Image::new(0, 0), 0),
        };
        assert!(cross_check(&empty, 1.0, &[(&g, 1.0)]).is_none());
        assert!(cross_check(&u, 1.0, &[]).is_none());
        assert!(cross_check(&u, 1.0, &[(&g, 1.0), (&one_half, 1.0)]).is_none());
        // An unguided image equal to the guided one: no error left to beat, so guiding never pays.
        let same = cross_check(&g, 1.0, &[(&g, 1.0)]).unwrap();
        assert_eq!(same.unguided_rel_error, 0.0);
        assert!(same.inefficiency_ratio.is_infinite());
    }

    #[test]
    fn a_comparison_resting_on_fireflies_or_on_nothing_shows_a_small_pixel_share() {
        let mut rng = TestRng::new(23);
        // Smooth noise everywhere: both estimates rest on most pixels.
        let u = iteration(&mut rng, 4, 0.2);
        let g = iteration(&mut rng, 4, 0.1);
        let c = cross_check(&u, 1.0, &[(&g, 1.0)]).unwrap();
        assert!(
            c.unguided_pixel_share > 0.3 && c.guided_pixel_share > 0.3,
            "{c:?}"
        );
        // A guided iteration that found a bright path in three pixels only, in a dark image: its error
        // estimate rests on those three.
        let dark = |rng: &mut TestRng| noisy(rng, -MEAN + 0.01, 0.0001);
        let mut found = IterationImage {
            a: (dark(&mut rng), 2),
            b: (dark(&mut rng), 2),
        };
        for p in [100, 2000, 9000] {
            found.a.0.rgb[p] = [50.0; 3];
        }
        let quiet = IterationImage {
            a: (dark(&mut rng), 2),
            b: (dark(&mut rng), 2),
        };
        let c = cross_check(&quiet, 1.0, &[(&found, 1.0)]).unwrap();
        assert!(c.guided_pixel_share < 1e-3, "{c:?}");
        assert!(c.unguided_pixel_share < 1e-3, "{c:?}");
        // Two black images: nothing to rest on.
        let black = IterationImage {
            a: (Image::new(SIDE, SIDE), 2),
            b: (Image::new(SIDE, SIDE), 2),
        };
        let c = cross_check(&black, 1.0, &[(&black, 1.0)]).unwrap();
        assert_eq!((c.unguided_pixel_share, c.guided_pixel_share), (0.0, 0.0));
        assert_eq!(effective_share(&[1.0, 1.0, 1.0, 1.0]), 1.0);
        assert_eq!(effective_share(&[0.0, 0.0, 4.0, 0.0]), 0.25);
    }
}
