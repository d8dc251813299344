//! `TrainingSegment::second_moment_with_fraction`: from segments sampled with one guide fraction, the
//! second moment another fraction would give, next-event estimation of the emission included.

mod gmm_common;

use focal_guiding::TrainingSegment;
use glam::Vec3;
use gmm_common::Rng;

/// A one-dimensional vertex on u ∈ [0, 1), like a floor point under a ceiling lamp: a light on [¼, ½)
/// emits F = 1 and NEE samples it with density 4, the guide has learned it (density 4 there too), the
/// BSDF samples uniformly, and light arriving deeper gives D = ½ on [0, ¾).
fn guide_pdf(u: f64) -> f64 {
    if (0.25..0.5).contains(&u) {
        4.0
    } else {
        0.0
    }
}
fn nee_pdf(u: f64) -> f64 {
    if (0.25..0.5).contains(&u) {
        4.0
    } else {
        0.0
    }
}
fn emission(u: f64) -> f64 {
    if (0.25..0.5).contains(&u) {
        1.0
    } else {
        0.0
    }
}
fn deeper(u: f64) -> f64 {
    if u < 0.75 {
        0.5
    } else {
        0.0
    }
}
fn power(p: f64, q: f64) -> f64 {
    if p > 0.0 {
        p * p / (p * p + q * q)
    } else {
        0.0
    }
}

/// What the renderer records for direction u sampled with fraction `alpha0`.
fn segment(u: f64, alpha0: f64) -> TrainingSegment {
    let (pg, pb, pn) = (guide_pdf(u), 1.0, nee_pdf(u));
    let p0 = alpha0 * pg + (1.0 - alpha0) * pb;
    let emitted = emission(u) * power(p0, pn) / p0;
    TrainingSegment {
        origin: Vec3::ZERO,
        direction: Vec3::Z,
        distance: 1.0,
        weight: (deeper(u) / p0 + emitted) as f32,
        pdf: p0 as f32,
        bsdf_pdf: pb as f32,
        guide_pdf: pg as f32,
        guide_fraction: alpha0 as f32,
        glossy_endpoint: false,
        glossy_origin: false,
        refracting_endpoint: false,
        emitted: emitted as f32,
        emitter_pdf: pn as f32,
        pixel_weight: 1.0,
    }
}

/// The exact second moment with fraction a: ∫(D + F·w_a)²/p_a + ∫F²·w_n²/p_n (midpoint rule on a grid
/// whose cells never straddle a discontinuity, so exact up to rounding).
fn exact(a: f64) -> f64 {
    let n = 4096;
    (0..n)
        .map(|i| {
            let u = (i as f64 + 0.5) / n as f64;
            let pa = a * guide_pdf(u) + (1.0 - a);
            let pn = nee_pdf(u);
            let f = emission(u);
            let direction = (deeper(u) + f * power(pa, pn)).powi(2) / pa;
            let nee = if pn > 0.0 {
                (f * power(pn, pa)).powi(2) / pn
            } else {
                0.0
            };
            (direction + nee) / n as f64
        })
        .sum()
}

#[test]
fn reweighted_moments_match_the_exact_ones_for_every_fraction() {
    let alpha0 = 0.75;
    let mut rng = Rng(7);
    let n = 400_000;
    let candidates = [0.0f32, 0.25, 0.5, 0.75, 0.9];
    let mut sums = [0.0f64; 5];
    for _ in 0..n {
        let u = if rng.f64() < alpha0 {
            0.25 + 0.25 * rng.f64()
        } else {
            rng.f64()
        };
        let s = segment(u, alpha0);
        for (sum, &a) in sums.iter_mut().zip(&candidates) {
            *sum += s.second_moment_with_fraction(a).unwrap();
        }
    }
    for (sum, &a) in sums.iter().zip(&candidates) {
        let estimate = sum / n as f64;
        let truth = exact(a as f64);
        assert!(
            (estimate / truth - 1.0).abs() < 0.01,
            "a = {a}: estimated {estimate}, exact {truth}"
        );
    }
    // The naive reweighting c²·p₀/p_a keeps the MIS weights the samples had, so it overstates what a
    // small fraction costs relative to the sampled one (NEE would take the light over): it would make
    // the guide look more useful than it is (0.58 against the exact 0.44 here).
    let naive = |a: f64| -> f64 {
        let mut rng = Rng(7);
        (0..n)
            .map(|_| {
                let u = if rng.f64() < alpha0 {
                    0.25 + 0.25 * rng.f64()
                } else {
                    rng.f64()
                };
                let s = segment(u, alpha0);
                let pa = a * s.guide_pdf as f64 + (1.0 - a) * s.bsdf_pdf as f64;
                (s.weight as f64).powi(2) * s.pdf as f64 / pa
            })
            .sum::<f64>()
            / n as f64
    };
    let (naive_ratio, exact_ratio) = (naive(0.0) / naive(0.75), exact(0.0) / exact(0.75));
    assert!(
        naive_ratio > 1.2 * exact_ratio,
        "naive {naive_ratio}, exact {exact_ratio}"
    );
}

#[test]
fn without_emission_it_is_the_plain_reweighting_times_the_pixel_weight() {
    let mut s = segment(0.6, 0.5);
    assert_eq!(s.emitted, 0.0);
    s.pixel_weight = 0.25;
    let c = s.weight as f64;
    for a in [0.0f32, 0.3, 0.9] {
        let pa = a as f64 * s.guide_pdf as f64 + (1.0 - a as f64) * s.bsdf_pdf as f64;
        let expected = 0.25 * c * c * s.pdf as f64 / pa;
        let got = s.second_moment_with_fraction(a).unwrap();
        assert!((got / expected - 1.0).abs() < 1e-12, "{got} vs {expected}");
    }
    // At the fraction it was sampled with, the segment's own c² (emission included, plus NEE's term).
    let e = segment(0.3, 0.75);
    let own = e.second_moment_with_fraction(0.75).unwrap();
    assert!(own >= (e.weight as f64).powi(2));
}

#[test]
fn impossible_fractions_and_invalid_segments() {
    // The guide alone cannot reach u ≥ ½, where deeper light arrives: a = 1 costs infinitely.
    let s = segment(0.6, 0.5);
    assert_eq!(s.second_moment_with_fraction(1.0), Some(f64::INFINITY));
    // A pixel of weight 0 teaches nothing, even there.
    let mut zero = s;
    zero.pixel_weight = 0.0;
    assert_eq!(zero.second_moment_with_fraction(1.0), Some(0.0));
    for broken in [
        TrainingSegment { pdf: 0.0, ..s },
        TrainingSegment {
            weight: f32::NAN,
            ..s
        },
        TrainingSegment {
            bsdf_pdf: -1.0,
            ..s
        },
        TrainingSegment {
            emitter_pdf: f32::INFINITY,
            ..s
        },
        TrainingSegment {
            pixel_weight: f32::NAN,
            ..s
        },
    ] {
        assert_eq!(broken.second_moment_with_fraction(0.5), None, "{broken:?}");
    }
}
