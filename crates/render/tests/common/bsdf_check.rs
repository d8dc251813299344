//! The statistical check of one BSDF at one incident direction, shared by the BSDF test files:
//! chi-square goodness of fit of `sample` against `pdf` (non-delta part), consistency of the sample
//! weight with eval/pdf, and the white-furnace energy bound, all on the same samples.

use focal_render::bsdf::{Bsdf, BsdfContext};
use focal_render::color::Rgb;
use focal_testkit::{chi2_sphere_test, Chi2Options};
use glam::Vec3;

/// What a test case expects of the white-furnace mean E[weight · η²] (η² undoes the radiance scaling
/// of refraction, so that energy conservation is tested).
#[derive(Clone, Copy, Debug)]
pub enum Energy {
    /// ≈ 1 (lossless model with unit reflectances).
    One,
    /// ≤ 1 (lossy model, e.g. microfacet shadowing).
    AtMostOne,
}

/// One BSDF queried from one incident direction.
pub struct Case {
    pub name: String,
    pub bsdf: Bsdf,
    pub wi: Vec3,
    pub energy: Energy,
}

/// Checks `case` at `ctx`; `num_tests` is the size of the test family (Šidák correction). Returns the
/// failures, each a line naming the case.
pub fn check_case(case: &Case, ctx: &BsdfContext, num_tests: usize) -> Vec<String> {
    let mut failures = Vec::new();
    let bsdf = &case.bsdf;
    let wi = case.wi;
    let mut weight_sum = 0.0f64;
    let mut count = 0usize;
    let mut worst_consistency = 0.0f32;
    let mut consistency_note = String::new();
    let opts = Chi2Options {
        num_tests,
        samples: 150_000,
        ..Chi2Options::default()
    };
    let result = chi2_sphere_test(
        |u2, u1| {
            count += 1;
            let s = bsdf.sample(ctx, wi, u1, u2)?;
            assert!(
                s.weight.is_finite() && s.pdf.is_finite() && s.wo.is_finite(),
                "{}: non-finite sample {s:?}",
                case.name
            );
            assert!(
                s.weight.min_element() >= 0.0,
                "{}: negative weight {s:?}",
                case.name
            );
            weight_sum += (s.weight.x * s.eta * s.eta) as f64;
            if s.delta {
                return Some((s.wo, 0.0));
            }
            let eval = bsdf.eval(ctx, wi, s.wo);
            let pdf = bsdf.pdf(ctx, wi, s.wo);
            let expected = eval / pdf;
            let err_w =
                ((s.weight - expected).abs() / expected.abs().max(Rgb::splat(1e-3))).max_element();
            // The pdf is recomputed from a reconstructed half vector, which loses some precision.
            let err_p = 0.1 * (s.pdf - pdf).abs() / pdf.max(1e-3);
            let err = err_w.max(err_p);
            if err > worst_consistency {
                worst_consistency = err;
                consistency_note = format!(
                    "wo {:?}: weight {} vs eval/pdf {}, pdf {} vs {}",
                    s.wo, s.weight, expected, s.pdf, pdf
                );
            }
            Some((s.wo, 1.0))
        },
        |wo| bsdf.pdf(ctx, wi, wo) as f64,
        opts,
    );
    if !result.passed {
        failures.push(format!("{}: chi2 {result}", case.name));
    }
    if worst_consistency > 1e-3 {
        failures.push(format!(
            "{}: sample weight/pdf inconsistent (rel. err {worst_consistency:.2e}): {consistency_note}",
            case.name
        ));
    }
    let mean = weight_sum / count as f64;
    let ok = match case.energy {
        Energy::One => (mean - 1.0).abs() < 0.01,
        Energy::AtMostOne => mean < 1.01,
    };
    if !ok {
        failures.push(format!(
            "{}: white furnace mean {mean:.4} violates {:?}",
            case.name, case.energy
        ));
    }
    failures
}
