//! The GMM guide's sampling and pdf agree: the pdf integrates to 1 (sphere, or hemisphere when
//! truncated), the truncated pdf is the full pdf over the hemisphere mass, and sampled directions pass
//! chi-square tests against the pdf; a reused sampling distribution gives the same bits as a fresh one.

mod gmm_common;

use focal_guiding::gmm::{GmmConfig, GmmGuide, Mixture};
use focal_guiding::octree::{FocalOctreeGuide, OctreeGuideConfig};
use focal_guiding::{Aabb3, GuidingField, SamplingDistribution};
use focal_testkit::{chi2_sphere_test, sphere_integral, Chi2Options};
use glam::{DVec3, Vec3};
use gmm_common::{random_mixture, Rng};
use statrs::distribution::{ContinuousCDF, Normal};

/// Chi-square tests in this file (Šidák family size).
const CHI2_TESTS: usize = 7;

fn world_box() -> Aabb3 {
    Aabb3 {
        min: Vec3::splat(-4.0),
        max: Vec3::splat(4.0),
    }
}

fn guide(conv: &Mixture, div: &Mixture, p_div: f64) -> GmmGuide {
    GmmGuide::from_mixtures(world_box(), GmmConfig::default(), conv, div, p_div).unwrap()
}

/// A direction drawn independently of the library: Box–Muller normals through each component's own
/// Cholesky-free square root (eigen-decomposition), mixture chosen with p_div.
fn independent_direction(
    rng: &mut Rng,
    conv: &Mixture,
    div: &Mixture,
    p_div: f64,
    x: DVec3,
) -> DVec3 {
    let diverging = rng.f64() < p_div;
    let m = if diverging { div } else { conv };
    let weights = m.weights();
    let mut u = rng.f64();
    let mut k = 0;
    while k + 1 < m.len() && u >= weights[k] {
        u -= weights[k];
        k += 1;
    }
    let g = &m.components()[k];
    let (values, vectors) = g.covariance().eigen();
    let mut y = g.mean();
    for (l, v) in values.iter().zip(vectors) {
        y += v * (l.sqrt() * rng.normal());
    }
    let d = (y - x).normalize();
    if diverging {
        -d
    } else {
        d
    }
}

/// Z = Σ (1 − p_div) π_k Φ(n·(μ_k − x)/σₙ) + p_div π_k Φ(−n·(μ_k − x)/σₙ), computed with statrs.
fn hemisphere_mass(conv: &Mixture, div: &Mixture, p_div: f64, x: DVec3, n: DVec3) -> f64 {
    let std = Normal::new(0.0, 1.0).unwrap();
    let side = |m: &Mixture, sign: f64| -> f64 {
        m.weights()
            .iter()
            .zip(m.components())
            .map(|(w, g)| {
                let sigma = g.covariance().quad(n).sqrt();
                w * std.cdf(sign * n.dot(g.mean() - x) / sigma)
            })
            .sum()
    };
    (1.0 - p_div) * side(conv, 1.0) + p_div * side(div, -1.0)
}

/// Monte Carlo ∫ pdf over the sphere (or the hemisphere of `normal`) with the defensive proposal
/// ½ uniform + ½ independent mixture sampling.
fn mc_integral(
    guide: &GmmGuide,
    (conv, div, p_div): (&Mixture, &Mixture, f64),
    x: DVec3,
    normal: Option<DVec3>,
    rng: &mut Rng,
    n: usize,
) -> (f64, f64) {
    let uniform = 1.0 / (4.0 * std::f64::consts::PI);
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let d = if rng.f64() < 0.5 {
            rng.sphere()
        } else {
            independent_direction(rng, conv, div, p_div, x)
        };
        let full = guide.pdf_f64(x.as_vec3(), None, d.as_vec3());
        let q = 0.5 * uniform + 0.5 * full;
        let p = guide.pdf_f64(x.as_vec3(), normal.map(|v| v.as_vec3()), d.as_vec3());
        let f = p / q;
        sum += f;
        sum2 += f * f;
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(0.0);
    (mean, (var / n as f64).sqrt())
}

#[test]
fn untrained_guide_samples_nothing() {
    let g = GmmGuide::new(world_box(), GmmConfig::default()).unwrap();
    assert_eq!(g.name(), "gmm");
    assert!(!g.is_trained());
    assert_eq!(g.sample_at(Vec3::ZERO, None, [0.3, 0.4, 0.5]), None);
    assert_eq!(
        g.sample_at(Vec3::ZERO, Some(Vec3::Z), [0.3, 0.4, 0.5]),
        None
    );
    assert_eq!(g.pdf_at(Vec3::ZERO, None, Vec3::X), 0.0);
}

#[test]
fn pdf_integrates_to_one_over_the_sphere() {
    let mut rng = Rng(3);
    for case in 0..12 {
        let conv = random_mixture(
            &mut rng,
            1 + case % 4,
            DVec3::new(0.5, 0.2, -0.3),
            0.05,
            0.6,
        );
        let div = random_mixture(&mut rng, 1 + case % 3, DVec3::new(-1.0, 0.5, 0.5), 0.1, 0.8);
        let p_div = [0.0, 0.3, 0.7][case % 3];
        let g = guide(&conv, &div, p_div);
        // Inside the mixtures, next to them and far away.
        let x = match case % 3 {
            0 => conv.components()[0].mean() + rng.sphere() * 0.05,
            1 => rng.sphere() * 1.5,
            _ => rng.sphere() * 3.5,
        };
        let (mc, err) = mc_integral(&g, (&conv, &div, p_div), x, None, &mut rng, 100_000);
        assert!(
            (mc - 1.0).abs() < 5.0 * err + 2e-3,
            "case {case}: ∫pdf = {mc} ± {err}"
        );
        if case % 3 != 0 {
            // Deterministic quadrature where the lobes are resolvable.
            let q = sphere_integral(|d| g.pdf_f64(x.as_vec3(), None, d));
            assert!((q - 1.0).abs() < 5e-3, "case {case}: quadrature ∫pdf = {q}");
        }
    }
}

#[test]
fn truncated_pdf_is_the_full_pdf_over_the_hemisphere_mass_and_integrates_to_one() {
    let mut rng = Rng(7);
    for case in 0..12 {
        let conv = random_mixture(&mut rng, 1 + case % 4, DVec3::new(0.3, 0.0, 0.2), 0.05, 0.6);
        let div = random_mixture(
            &mut rng,
            1 + case % 2,
            DVec3::new(-0.5, 0.5, -0.4),
            0.1,
            0.5,
        );
        let p_div = [0.0, 0.4, 0.8][case % 3];
        let g = guide(&conv, &div, p_div);
        // The guide sees f32 inputs: give the oracle exactly the same point and normal.
        let x = (rng.sphere() * (0.2 + 1.5 * rng.f64()))
            .as_vec3()
            .as_dvec3();
        let n = rng.sphere().as_vec3().as_dvec3().normalize();
        let z = hemisphere_mass(&conv, &div, p_div, x, n);
        if z < 1e-4 {
            continue;
        }
        for _ in 0..200 {
            let d = rng.sphere();
            let full = g.pdf_f64(x.as_vec3(), None, d.as_vec3());
            let trunc = g.pdf_f64(x.as_vec3(), Some(n.as_vec3()), d.as_vec3());
            if d.dot(n) <= 1e-6 {
                if d.dot(n) < -1e-6 {
                    assert_eq!(trunc, 0.0);
                }
            } else {
                // statrs' Φ is accurate to about 1e-10 relative.
                assert!(
                    (trunc - full / z).abs() <= 1e-8 * trunc.max(1e-300),
                    "case {case}: {trunc} vs {}",
                    full / z
                );
            }
        }
        let (mc, err) = mc_integral(&g, (&conv, &div, p_div), x, Some(n), &mut rng, 100_000);
        assert!(
            (mc - 1.0).abs() < 5.0 * err + 3e-3,
            "case {case}: ∫ truncated pdf = {mc} ± {err} (Z = {z})"
        );
    }
}

fn chi2(g: &GmmGuide, x: Vec3, normal: Option<Vec3>, seed: u64) {
    let opts = Chi2Options {
        num_tests: CHI2_TESTS,
        seed,
        ..Chi2Options::default()
    };
    let mut mismatched = 0u32;
    let r = chi2_sphere_test(
        |u2, u1| {
            let s = g.sample_at(x, normal, [u1, u2.x, u2.y])?;
            if s.pdf.to_bits() != g.pdf_at(x, normal, s.direction).to_bits() {
                mismatched += 1;
            }
            if let Some(n) = normal {
                assert!(s.direction.dot(n) > 0.0, "sampled below the surface");
            }
            Some((s.direction, 1.0))
        },
        |d| g.pdf_at(x, normal, d) as f64,
        opts,
    );
    assert_eq!(mismatched, 0, "sample() pdf differs from pdf()");
    assert!(r.passed, "{r}");
    assert!((r.pdf_integral - 1.0).abs() < 3e-3, "{r}");
}

#[test]
fn chi_square_full_sphere_inside_the_mixture() {
    let mut rng = Rng(21);
    let conv = random_mixture(&mut rng, 3, DVec3::new(0.3, 0.0, 0.0), 0.2, 0.7);
    let g = guide(&conv, &Mixture::empty(), 0.0);
    chi2(
        &g,
        conv.components()[1].mean().as_vec3() + Vec3::new(0.05, 0.0, 0.0),
        None,
        1,
    );
}

#[test]
fn chi_square_full_sphere_converging_and_diverging() {
    let mut rng = Rng(22);
    let conv = random_mixture(&mut rng, 3, DVec3::new(1.0, 0.5, 0.0), 0.15, 0.5);
    let div = random_mixture(&mut rng, 2, DVec3::new(-1.0, -0.5, 0.3), 0.15, 0.5);
    let g = guide(&conv, &div, 0.35);
    chi2(&g, Vec3::new(0.0, 0.1, -0.2), None, 2);
}

#[test]
fn chi_square_truncated_half_the_mass() {
    let mut rng = Rng(23);
    let conv = random_mixture(&mut rng, 3, DVec3::new(0.0, 0.0, 0.3), 0.2, 0.6);
    let g = guide(&conv, &Mixture::empty(), 0.0);
    let n = Vec3::new(0.3, -0.2, 0.93).normalize();
    chi2(&g, Vec3::new(0.1, 0.0, 0.2), Some(n), 3);
}

#[test]
fn chi_square_truncated_mass_mostly_below_the_surface() {
    // Most of the mixture lies below the tangent plane: the sampler lives in the components' tails.
    let mut rng = Rng(24);
    let conv = random_mixture(&mut rng, 2, DVec3::new(0.0, 0.0, -1.0), 0.2, 0.4);
    let g = guide(&conv, &Mixture::empty(), 0.0);
    let x = Vec3::new(0.0, 0.0, -0.2);
    let z = hemisphere_mass(&conv, &Mixture::empty(), 0.0, x.as_dvec3(), DVec3::Z);
    assert!(z < 0.05 && z > 1e-4, "Z = {z}");
    chi2(&g, x, Some(Vec3::Z), 4);
}

#[test]
fn chi_square_truncated_with_both_mixtures() {
    let mut rng = Rng(25);
    let conv = random_mixture(&mut rng, 2, DVec3::new(0.5, 0.5, 0.5), 0.2, 0.5);
    let div = random_mixture(&mut rng, 3, DVec3::new(0.3, -0.6, 0.2), 0.2, 0.5);
    let g = guide(&conv, &div, 0.5);
    chi2(
        &g,
        Vec3::new(0.0, 0.0, 0.0),
        Some(Vec3::new(0.0, 0.6, 0.8)),
        5,
    );
}

#[test]
fn chi_square_elongated_components_far_away() {
    // Thin, strongly anisotropic components a few σ away: narrow directional lobes.
    let mut rng = Rng(26);
    let conv = random_mixture(&mut rng, 3, DVec3::new(2.0, 0.0, 0.0), 0.05, 0.8);
    let div = random_mixture(&mut rng, 1, DVec3::new(0.0, 2.0, 0.0), 0.05, 0.8);
    let g = guide(&conv, &div, 0.2);
    chi2(&g, Vec3::new(0.0, 0.0, 0.0), None, 6);
    chi2(
        &g,
        Vec3::new(0.0, 0.0, 0.0),
        Some(Vec3::new(1.0, 1.0, 0.2).normalize()),
        7,
    );
}

#[test]
fn hemisphere_without_guide_mass_is_empty() {
    // The whole mixture far below the plane: no sample, pdf 0, consistently.
    let mut rng = Rng(27);
    let conv = random_mixture(&mut rng, 2, DVec3::new(0.0, 0.0, -3.0), 0.05, 0.1);
    let g = guide(&conv, &Mixture::empty(), 0.0);
    for i in 0..100 {
        let u = [i as f32 / 100.0, 0.5, 0.25];
        assert_eq!(g.sample_at(Vec3::ZERO, Some(Vec3::Z), u), None);
    }
    assert_eq!(g.pdf_at(Vec3::ZERO, Some(Vec3::Z), Vec3::Z), 0.0);
    assert!(g.pdf_at(Vec3::ZERO, None, -Vec3::Z) > 0.0);
}

#[test]
fn chi_square_detects_a_sampler_that_disagrees_with_its_pdf() {
    // The prototype's bug in miniature: directions drawn with p_div = 0.35 but a pdf that uses 0.45.
    let mut rng = Rng(28);
    let conv = random_mixture(&mut rng, 2, DVec3::new(1.0, 0.5, 0.0), 0.2, 0.5);
    let div = random_mixture(&mut rng, 2, DVec3::new(-1.0, -0.5, 0.3), 0.2, 0.5);
    let sampler = guide(&conv, &div, 0.35);
    let claimed = guide(&conv, &div, 0.45);
    let x = Vec3::new(0.0, 0.1, -0.2);
    let r = chi2_sphere_test(
        |u2, u1| {
            let s = sampler.sample_at(x, None, [u1, u2.x, u2.y])?;
            Some((s.direction, 1.0))
        },
        |d| claimed.pdf_at(x, None, d) as f64,
        Chi2Options::default(),
    );
    assert!(!r.passed, "{r}");
}

#[test]
fn a_reused_distribution_gives_what_a_fresh_one_does_bit_for_bit() {
    // One distribution per thread serves NEE, sampling and the BSDF direction's pdf at every vertex:
    // it must not change a single bit of what a fresh one gives, with and without a hemisphere hint,
    // and it must forget the previous point, also one of another guide.
    let mut rng = Rng(31);
    let conv = random_mixture(&mut rng, 5, DVec3::ZERO, 0.05, 0.6);
    let div = random_mixture(&mut rng, 3, DVec3::new(1.0, 0.5, 0.0), 0.1, 0.4);
    let g = guide(&conv, &div, 0.3);
    let octree = FocalOctreeGuide::new(world_box(), OctreeGuideConfig::default()).unwrap();
    let mut distribution = SamplingDistribution::default();
    for i in 0..200 {
        let x = rng.in_box(DVec3::splat(-2.0), DVec3::splat(2.0)).as_vec3();
        let normal = (i % 3 != 0).then(|| rng.sphere().as_vec3());
        if i % 7 == 0 {
            octree.init(&mut distribution, x, normal);
            assert!(matches!(distribution, SamplingDistribution::Octree(_)));
            // Another guide's distribution is none of the mixture's.
            assert_eq!(g.pdf(&distribution, Vec3::Z), 0.0);
        }
        g.init(&mut distribution, x, normal);
        let u = [rng.f32(), rng.f32(), rng.f32()];
        let plain = g.sample_at(x, normal, u);
        assert_eq!(g.sample(&distribution, u), plain);
        for d in [
            rng.sphere().as_vec3(),
            plain.map_or(Vec3::Z, |s| s.direction),
        ] {
            assert_eq!(
                g.pdf(&distribution, d).to_bits(),
                g.pdf_at(x, normal, d).to_bits()
            );
        }
    }
}
