//! The renderer's single-precision pdf kernel against the `f64` reference: its special functions
//! against [`focal_guiding::gmm::special`], and the guide's pdf (`f32` kernel) against
//! [`GmmGuide::pdf_f64`] for random mixtures, shading points inside and far outside components, tiny
//! distant components and truncation to a hemisphere.

mod gmm_common;

use focal_guiding::gmm::special::{exp_fast, half_line_h, mills_ratio, norm_cdf};
use focal_guiding::gmm::special32::{exp_f32, half_line_h_f32, mills_ratio_f32, norm_cdf_f32};
use focal_guiding::gmm::{Gaussian3, GmmConfig, GmmGuide, Mixture, Sym3};
use focal_guiding::{Aabb3, GuidingField};
use glam::{DVec3, Vec3};
use gmm_common::{random_mixture, Rng};

fn rel_err(approx: f64, exact: f64) -> f64 {
    (approx - exact).abs() / exact.abs()
}

#[test]
fn single_precision_special_functions_match_the_f64_ones() {
    let mut worst = [0.0f64; 4];
    for i in 0..=20_000 {
        // β from 0 to 400, denser near 0 where the functions bend most.
        let t = i as f64 / 20_000.0;
        let beta = 400.0 * t * t * t;
        let b32 = beta as f32;
        // Compare at the f32 argument, so that only the functions' own error is measured.
        let b = b32 as f64;
        worst[0] = worst[0].max(rel_err(half_line_h_f32(b32) as f64, half_line_h(b)));
        worst[1] = worst[1].max(rel_err(mills_ratio_f32(b32) as f64, mills_ratio(b)));
        if b < 13.0 {
            let k = -b32;
            worst[2] = worst[2].max(rel_err(norm_cdf_f32(k) as f64, norm_cdf(k as f64)));
            let k = b32;
            worst[2] = worst[2].max(rel_err(norm_cdf_f32(k) as f64, norm_cdf(k as f64)));
        }
        let x = (-87.0 + 175.0 * t) as f32;
        worst[3] = worst[3].max(rel_err(exp_f32(x) as f64, exp_fast(x as f64)));
    }
    println!(
        "worst relative errors: H {:.2e}, R {:.2e}, Φ {:.2e}, exp {:.2e}",
        worst[0], worst[1], worst[2], worst[3]
    );
    assert!(worst[0] < 1e-6, "H: {:e}", worst[0]);
    assert!(worst[1] < 1e-6, "R: {:e}", worst[1]);
    // Far in the lower tail Φ inherits the f32 rounding of k²/2 (about 84·6e-8 at k = −13).
    assert!(worst[2] < 1e-5, "Φ: {:e}", worst[2]);
    assert!(worst[3] < 5e-7, "exp: {:e}", worst[3]);
    assert_eq!(exp_f32(-88.0), 0.0);
    assert_eq!(exp_f32(f32::NEG_INFINITY), 0.0);
    assert_eq!(norm_cdf_f32(-20.0), 0.0);
    assert_eq!(norm_cdf_f32(20.0), 1.0);
    assert_eq!(half_line_h_f32(f32::INFINITY), 0.0);
}

fn world_box() -> Aabb3 {
    Aabb3 {
        min: Vec3::splat(-4.0),
        max: Vec3::splat(4.0),
    }
}

/// Largest relative deviation of the guide's `f32` pdf from the `f64` reference over random directions,
/// counting only directions whose reference pdf is above `floor` of the largest one seen (below that a
/// direction is never sampled from the guide and its pdf only enters MIS as a negligible term).
fn worst_deviation(
    g: &GmmGuide,
    x: Vec3,
    normal: Option<Vec3>,
    rng: &mut Rng,
    dirs: &[Vec3],
) -> f64 {
    let mut pairs = Vec::new();
    for d in dirs {
        pairs.push((g.pdf_at(x, normal, *d) as f64, g.pdf_f64(x, normal, *d)));
    }
    // Directions the guide itself samples: near its peaks, where accuracy matters most.
    for _ in 0..400 {
        let u = [rng.f32(), rng.f32(), rng.f32()];
        if let Some(s) = g.sample_at(x, normal, u) {
            assert_eq!(s.pdf.to_bits(), g.pdf_at(x, normal, s.direction).to_bits());
            pairs.push((s.pdf as f64, g.pdf_f64(x, normal, s.direction)));
        }
    }
    let peak = pairs.iter().map(|p| p.1).fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for (fast, exact) in pairs {
        assert!(fast.is_finite() && fast >= 0.0);
        if exact > 1e-9 * peak {
            worst = worst.max(rel_err(fast, exact));
        } else {
            assert!(
                fast <= 1e-8 * peak + 1e-30,
                "{fast} where the reference is {exact}"
            );
        }
    }
    worst
}

#[test]
fn the_f32_kernel_matches_the_f64_reference() {
    let mut rng = Rng(0x32_f32);
    let dirs: Vec<Vec3> = (0..300).map(|_| rng.sphere().as_vec3()).collect();
    let mut worst = 0.0f64;
    for case in 0..40 {
        // Broad to small components (σ 0.003–0.8 in a box of half-size 4).
        let conv = random_mixture(
            &mut rng,
            1 + case % 6,
            DVec3::new(0.3, -0.2, 0.5),
            0.003,
            0.8,
        );
        let div = random_mixture(
            &mut rng,
            1 + case % 3,
            DVec3::new(-1.0, 0.5, 0.0),
            0.01,
            0.5,
        );
        let p_div = [0.0, 0.3, 0.7][case % 3];
        let g =
            GmmGuide::from_mixtures(world_box(), GmmConfig::default(), &conv, &div, p_div).unwrap();
        // Inside the mixtures, near them, and across the box.
        let x =
            (DVec3::new(0.3, -0.2, 0.5) + rng.sphere() * [0.0, 0.05, 1.0, 3.0][case % 4]).as_vec3();
        let normal = (case % 2 == 1).then(|| rng.sphere().as_vec3());
        worst = worst.max(worst_deviation(&g, x, normal, &mut rng, &dirs));
    }
    println!("worst relative deviation of the f32 kernel: {worst:.2e}");
    assert!(worst < 2e-5, "{worst:e}");
}

#[test]
fn the_f32_kernel_handles_tiny_distant_components() {
    // A focus of σ = 2e-4 seen from 6 units away (|L⁻¹(μ − x)| = 3e4, an extreme pinhole), beside a
    // broad component: the f32 rounding of the whitened offset bounds the error (see the kernel's doc).
    let mut rng = Rng(77);
    let tiny = Gaussian3::new(
        DVec3::new(1.0, 1.0, 1.0),
        Sym3::diagonal(DVec3::splat(4e-8)),
    )
    .unwrap();
    let broad = Gaussian3::new(DVec3::ZERO, Sym3::diagonal(DVec3::splat(1.0))).unwrap();
    let conv = Mixture::new(&[0.5, 0.5], vec![tiny, broad]).unwrap();
    let g = GmmGuide::from_mixtures(
        world_box(),
        GmmConfig::default(),
        &conv,
        &Mixture::empty(),
        0.0,
    )
    .unwrap();
    let x = Vec3::new(-2.5, -2.5, -2.5);
    let dirs: Vec<Vec3> = (0..300).map(|_| rng.sphere().as_vec3()).collect();
    let worst = worst_deviation(&g, x, None, &mut rng, &dirs);
    println!("tiny distant focus: worst relative deviation {worst:.2e}");
    assert!(worst < 2e-2, "{worst:e}");
    // Every direction sampled towards the focus gets a finite, positive pdf near the reference.
    let towards = (Vec3::ONE - x).normalize();
    let p = g.pdf_at(x, None, towards) as f64;
    assert!(rel_err(p, g.pdf_f64(x, None, towards)) < 2e-2);
}
