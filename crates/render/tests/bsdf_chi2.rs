//! Statistical tests of every BSDF: chi-square goodness of fit of `sample` against `pdf` (non-delta
//! part), consistency of the sample weight with eval/pdf, white-furnace energy bounds (see
//! common/bsdf_check.rs), and reciprocity. The adapters of Mitsuba 0.6 scenes (mixturebsdf, bumpmap,
//! coating) are in bsdf_adapters.rs.

use focal_render::bsdf::{
    Blend, Bsdf, BsdfContext, Conductor, Dielectric, Diffuse, DiffuseTransmitter, Mask, Microfacet,
    MicrofacetKind, NormalMap, Phong, Plastic, RoughConductor, RoughDielectric, RoughPlastic,
    ThinDielectric, TwoSided, Ward, WardVariant,
};
use focal_render::color::Rgb;
use focal_render::texture::Texture;
use focal_testkit::{chi2_sphere_test, Chi2Options, TestRng};
use glam::{Vec2, Vec3};

mod common;

use common::bsdf_check::{check_case, Case, Energy};

const ETA: f32 = 1.5;

fn white() -> Texture {
    Texture::constant(1.0)
}

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn diffuse(r: f32) -> Bsdf {
    Bsdf::Diffuse(Diffuse {
        reflectance: Texture::constant(r),
    })
}

fn rough_conductor(kind: MicrofacetKind, au: f32, av: f32, visible: bool) -> Bsdf {
    Bsdf::RoughConductor(Box::new(RoughConductor {
        distribution: Microfacet::new(kind, au, av, visible),
        eta: Texture::Constant(Rgb::ZERO),
        k: Texture::Constant(Rgb::ONE),
        specular_reflectance: white(),
    }))
}

fn rough_dielectric(kind: MicrofacetKind, au: f32, av: f32, visible: bool) -> Bsdf {
    Bsdf::RoughDielectric(Box::new(RoughDielectric {
        distribution: Microfacet::new(kind, au, av, visible),
        eta: ETA,
        specular_reflectance: white(),
        specular_transmittance: white(),
    }))
}

fn rough_plastic(kind: MicrofacetKind, alpha: f32, diffuse: f32, nonlinear: bool) -> Bsdf {
    Bsdf::RoughPlastic(Box::new(RoughPlastic::new(
        kind,
        alpha,
        true,
        ETA,
        Texture::constant(diffuse),
        None,
        nonlinear,
    )))
}

fn plastic(diffuse: f32, nonlinear: bool) -> Bsdf {
    Bsdf::Plastic(Box::new(Plastic::new(
        ETA,
        Texture::constant(diffuse),
        None,
        nonlinear,
    )))
}

fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    let mut add = |name: String, bsdf: &Bsdf, wis: &[Vec3], energy: Energy| {
        for (i, wi) in wis.iter().enumerate() {
            out.push(Case {
                name: format!("{name} wi#{i}"),
                bsdf: bsdf.clone(),
                wi: *wi,
                energy,
            });
        }
    };
    let front = [dir(0.0, 0.0), dir(45.0, 30.0), dir(80.0, 200.0)];
    let both = [
        dir(0.0, 0.0),
        dir(80.0, 30.0),
        dir(150.0, 70.0),
        dir(100.0, 250.0),
    ];

    add("diffuse".into(), &diffuse(1.0), &front, Energy::One);
    add(
        "conductor none".into(),
        &Bsdf::Conductor(Box::new(Conductor {
            eta: Texture::Constant(Rgb::ZERO),
            k: Texture::Constant(Rgb::ONE),
            specular_reflectance: white(),
        })),
        &front,
        Energy::One,
    );
    for kind in [MicrofacetKind::Beckmann, MicrofacetKind::Ggx] {
        for alpha in [0.05f32, 0.3, 0.8] {
            add(
                format!("roughconductor {kind:?} α={alpha}"),
                &rough_conductor(kind, alpha, alpha, true),
                &front,
                Energy::AtMostOne,
            );
            add(
                format!("roughdielectric {kind:?} α={alpha}"),
                &rough_dielectric(kind, alpha, alpha, true),
                &both,
                Energy::AtMostOne,
            );
            add(
                format!("roughplastic {kind:?} α={alpha}"),
                &rough_plastic(kind, alpha, 1.0, false),
                &front,
                Energy::AtMostOne,
            );
        }
        add(
            format!("roughconductor {kind:?} aniso"),
            &rough_conductor(kind, 0.05, 0.4, true),
            &front,
            Energy::AtMostOne,
        );
        add(
            format!("roughdielectric {kind:?} aniso"),
            &rough_dielectric(kind, 0.4, 0.1, true),
            &both,
            Energy::AtMostOne,
        );
        add(
            format!("roughconductor {kind:?} full NDF"),
            &rough_conductor(kind, 0.3, 0.15, false),
            &front,
            Energy::AtMostOne,
        );
        add(
            format!("roughdielectric {kind:?} full NDF"),
            &rough_dielectric(kind, 0.3, 0.3, false),
            &both,
            Energy::AtMostOne,
        );
    }
    add(
        "dielectric".into(),
        &Bsdf::Dielectric(Dielectric {
            eta: ETA,
            specular_reflectance: white(),
            specular_transmittance: white(),
        }),
        &both,
        Energy::One,
    );
    add(
        "thindielectric".into(),
        &Bsdf::ThinDielectric(ThinDielectric {
            eta: ETA,
            specular_reflectance: white(),
            specular_transmittance: white(),
        }),
        &both,
        Energy::One,
    );
    add(
        "plastic".into(),
        &plastic(1.0, false),
        &front,
        Energy::AtMostOne,
    );
    add(
        "plastic nonlinear".into(),
        &plastic(0.6, true),
        &front,
        Energy::AtMostOne,
    );
    add(
        "roughplastic nonlinear".into(),
        &rough_plastic(MicrofacetKind::Ggx, 0.2, 0.6, true),
        &front,
        Energy::AtMostOne,
    );
    let below = [dir(180.0, 0.0), dir(120.0, 40.0), dir(100.0, 300.0)];
    let ts = |front: Bsdf, back: Bsdf| Bsdf::TwoSided(TwoSided::new(front, back));
    add(
        "twosided diffuse".into(),
        &ts(diffuse(1.0), diffuse(1.0)),
        &below,
        Energy::One,
    );
    let rc = rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, true);
    add(
        "twosided roughconductor".into(),
        &ts(rc.clone(), rc.clone()),
        &below,
        Energy::AtMostOne,
    );
    add(
        "twosided diffuse|roughconductor".into(),
        &ts(diffuse(1.0), rc),
        &[dir(30.0, 10.0), dir(120.0, 40.0)],
        Energy::AtMostOne,
    );
    add(
        "twosided plastic".into(),
        &ts(plastic(1.0, false), plastic(1.0, false)),
        &below,
        Energy::AtMostOne,
    );
    // Normal maps tilt the nested model's frame by 35° (rgb = (n + 1) / 2); directions on different sides
    // of the two normals are masked, so energy can only be lost.
    let tilted = Vec3::new(35f32.to_radians().sin(), 0.0, 35f32.to_radians().cos());
    let nm = |nested: Bsdf| {
        Bsdf::NormalMap(Box::new(NormalMap {
            nested,
            normals: Texture::Constant((tilted + Vec3::ONE) * 0.5),
        }))
    };
    let nm_wis = [dir(0.0, 0.0), dir(60.0, 0.0), dir(70.0, 180.0)];
    add(
        "normalmap diffuse".into(),
        &nm(diffuse(1.0)),
        &nm_wis,
        Energy::AtMostOne,
    );
    add(
        "normalmap roughconductor".into(),
        &nm(rough_conductor(MicrofacetKind::Beckmann, 0.2, 0.2, true)),
        &nm_wis,
        Energy::AtMostOne,
    );
    let blend = |a: Bsdf, b: Bsdf, w: f32| {
        Bsdf::Blend(Box::new(Blend {
            bsdfs: Box::new([a, b]),
            weight: Texture::constant(w),
        }))
    };
    add(
        "blendbsdf diffuse|roughconductor".into(),
        &blend(
            diffuse(1.0),
            rough_conductor(MicrofacetKind::Ggx, 0.15, 0.15, true),
            0.3,
        ),
        &front,
        Energy::AtMostOne,
    );
    add(
        "blendbsdf diffuse|plastic".into(),
        &blend(diffuse(1.0), plastic(1.0, false), 0.6),
        &front,
        Energy::AtMostOne,
    );
    // Masks: the null event is a delta transmission with weight (1 − o)/P, so a white nested model
    // stays lossless; a colour opacity exercises the per-channel weights.
    let mask = |nested: Bsdf, o: Rgb| {
        Bsdf::Mask(Box::new(Mask {
            nested,
            opacity: Texture::Constant(o),
        }))
    };
    add(
        "mask diffuse o=0.5".into(),
        &mask(diffuse(1.0), Rgb::splat(0.5)),
        &front,
        Energy::One,
    );
    add(
        "mask diffuse o=(0.2,0.5,0.9)".into(),
        &mask(diffuse(1.0), Rgb::new(0.2, 0.5, 0.9)),
        &front,
        Energy::One,
    );
    add(
        "mask roughconductor o=0.7".into(),
        &mask(
            rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, true),
            Rgb::splat(0.7),
        ),
        &front,
        Energy::AtMostOne,
    );
    add(
        "mask twosided plastic o=0.3".into(),
        &mask(
            ts(plastic(1.0, false), plastic(1.0, false)),
            Rgb::splat(0.3),
        ),
        &below,
        Energy::AtMostOne,
    );
    for (n, spec) in [(30.0, 0.4), (3.0, 0.9)] {
        add(
            format!("phong n={n} s={spec}"),
            &Bsdf::Phong(Box::new(Phong::new(
                Texture::constant(n),
                Texture::constant(spec),
                Texture::constant(1.0 - spec),
            ))),
            &front,
            Energy::AtMostOne,
        );
    }
    for (variant, au, av) in [
        (WardVariant::Balanced, 0.2, 0.2),
        (WardVariant::Ward, 0.3, 0.1),
        (WardVariant::WardDuer, 0.15, 0.4),
    ] {
        add(
            format!("ward {variant:?} {au} {av}"),
            &Bsdf::Ward(Box::new(Ward::new(
                variant,
                au,
                av,
                Texture::constant(0.3),
                Texture::constant(0.3),
            ))),
            &front,
            Energy::AtMostOne,
        );
    }
    add(
        "difftrans".into(),
        &Bsdf::DiffuseTransmitter(DiffuseTransmitter {
            transmittance: white(),
        }),
        &both,
        Energy::One,
    );
    out
}

/// Chi-square, weight consistency and white-furnace energy, all on the same samples, for the cases whose
/// name starts with one of `prefixes`. The Šidák correction counts every case of [`cases`], so the whole
/// suite has a 1 % false-rejection probability.
fn check_cases(prefixes: &[&str]) {
    let ctx = BsdfContext::default();
    let all = cases();
    let num_tests = all.len();
    let cases: Vec<&Case> = all
        .iter()
        .filter(|c| prefixes.iter().any(|p| c.name.starts_with(p)))
        .collect();
    assert!(!cases.is_empty());
    let mut failures = Vec::new();
    for case in &cases {
        failures.extend(check_case(case, &ctx, num_tests));
    }
    assert!(
        failures.is_empty(),
        "{} failures in {} cases:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

#[test]
fn chi2_conductors_and_diffuse() {
    check_cases(&["diffuse", "conductor", "roughconductor"]);
}

#[test]
fn chi2_normalmap_and_blend() {
    check_cases(&["normalmap", "blendbsdf"]);
}

#[test]
fn chi2_dielectrics() {
    check_cases(&["dielectric", "roughdielectric", "thindielectric"]);
}

#[test]
fn chi2_plastics_and_twosided() {
    check_cases(&["plastic", "roughplastic", "twosided"]);
}

#[test]
fn chi2_phong_and_ward() {
    check_cases(&["phong", "ward"]);
}

#[test]
fn chi2_mask_and_difftrans() {
    check_cases(&["mask", "difftrans"]);
}

/// A mask's null event continues straight on with weight (1 − o)/mean(1 − o), chosen with probability
/// mean(1 − o); difftrans only transmits, from either side.
#[test]
fn mask_null_event_and_difftrans_sides() {
    let ctx = BsdfContext::default();
    let o = Rgb::new(0.2, 0.5, 0.9);
    let m = Bsdf::Mask(Box::new(Mask {
        nested: diffuse(0.8),
        opacity: Texture::Constant(o),
    }));
    let wi = dir(40.0, 60.0);
    let p_null = 1.0 - (0.2 + 0.5 + 0.9) / 3.0;
    let s = m.sample(&ctx, wi, 0.999, Vec2::new(0.3, 0.3)).unwrap();
    assert!(s.delta && (s.wo + wi).length() < 1e-6, "{s:?}");
    assert!((s.pdf - p_null).abs() < 1e-6);
    assert!(((s.weight - (Rgb::ONE - o) / p_null).abs()).max_element() < 1e-5);
    assert_eq!(m.pass_through(&ctx), Some(Rgb::ONE - o));
    assert!(matches!(m.opaque_part(), Bsdf::Diffuse(_)));
    assert!(diffuse(0.5).pass_through(&ctx).is_none());
    let wo = dir(30.0, 200.0);
    assert!(
        ((m.eval(&ctx, wi, wo) - diffuse(0.8).eval(&ctx, wi, wo) * o).abs()).max_element() < 1e-7
    );

    let t = Bsdf::DiffuseTransmitter(DiffuseTransmitter {
        transmittance: Texture::constant(0.6),
    });
    let (up, down) = (dir(20.0, 0.0), dir(160.0, 90.0));
    assert_eq!(t.eval(&ctx, up, dir(40.0, 0.0)), Rgb::ZERO);
    let f = t.eval(&ctx, up, down);
    assert!((f.x - 0.6 / std::f32::consts::PI * down.z.abs()).abs() < 1e-6);
    assert_eq!(
        t.eval(&ctx, down, up),
        t.eval(&ctx, up, down) * up.z.abs() / down.z.abs()
    );
    for wi in [up, down] {
        let s = t.sample(&ctx, wi, 0.5, Vec2::new(0.7, 0.2)).unwrap();
        assert!(s.wo.z * wi.z < 0.0 && !s.delta && (s.weight.x - 0.6).abs() < 1e-6);
    }
    assert!(t.has_smooth() && t.has_transmission() && !t.has_delta());
}

/// f(wi, wo) = f(wo, wi) for the reflection lobes (eval includes |cos θo|, so compare eval/|cos θo|).
#[test]
fn reflection_is_reciprocal() {
    let ctx = BsdfContext::default();
    let models = [
        diffuse(0.7),
        rough_conductor(MicrofacetKind::Beckmann, 0.2, 0.5, true),
        rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, true),
        rough_dielectric(MicrofacetKind::Ggx, 0.3, 0.3, true),
        rough_dielectric(MicrofacetKind::Beckmann, 0.5, 0.5, true),
        plastic(0.5, false),
        rough_plastic(MicrofacetKind::Beckmann, 0.3, 0.5, false),
    ];
    let mut rng = TestRng::new(7);
    for b in &models {
        for _ in 0..2000 {
            let u = |rng: &mut TestRng| Vec2::new(rng.next_f32(), rng.next_f32());
            let a = focal_render::warp::square_to_cosine_hemisphere(u(&mut rng));
            let c = focal_render::warp::square_to_cosine_hemisphere(u(&mut rng));
            if a.z < 1e-3 || c.z < 1e-3 {
                continue;
            }
            let fac = b.eval(&ctx, a, c) / c.z;
            let fca = b.eval(&ctx, c, a) / a.z;
            let err = ((fac - fca).abs() / fac.abs().max(Rgb::splat(1e-4))).max_element();
            assert!(
                err < 1e-3,
                "{b:?}: f({a}, {c}) = {fac} but f({c}, {a}) = {fca}"
            );
        }
    }
}

/// One-sided models are black from below; two-sided and dielectrics are not.
#[test]
fn sidedness() {
    let ctx = BsdfContext::default();
    let below = dir(150.0, 20.0);
    let below2 = dir(120.0, 200.0);
    for b in [
        diffuse(0.5),
        rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, true),
        plastic(0.5, false),
    ] {
        assert_eq!(b.eval(&ctx, below, below2), Rgb::ZERO);
        assert_eq!(b.pdf(&ctx, below, below2), 0.0);
        assert!(b.sample(&ctx, below, 0.3, Vec2::new(0.4, 0.6)).is_none());
    }
    let ts = Bsdf::TwoSided(TwoSided::new(diffuse(0.5), diffuse(0.5)));
    assert!(ts.eval(&ctx, below, below2).x > 0.0);
    let d = rough_dielectric(MicrofacetKind::Ggx, 0.3, 0.3, true);
    assert!(d.eval(&ctx, below, below2).x > 0.0);
}

/// The white-furnace albedo of the smooth plastic approaches Mitsuba's model: with a white base and
/// `nonlinear = false`, the diffuse part reflects (1 − F_i)·(1 − Fdr_ext)/((1 − Fdr_int)·η²) ≈ 1 − F_i.
#[test]
fn plastic_white_furnace_is_nearly_lossless() {
    let ctx = BsdfContext::default();
    let b = plastic(1.0, false);
    let mut rng = TestRng::new(3);
    let wi = dir(30.0, 0.0);
    let n = 200_000;
    let mut sum = 0.0f64;
    for _ in 0..n {
        if let Some(s) = b.sample(
            &ctx,
            wi,
            rng.next_f32(),
            Vec2::new(rng.next_f32(), rng.next_f32()),
        ) {
            sum += s.weight.x as f64;
        }
    }
    let mean = sum / n as f64;
    assert!(mean > 0.97 && mean < 1.01, "{mean}");
}

/// Flags and roughness summaries.
#[test]
fn flags_and_roughness() {
    let rc = rough_conductor(MicrofacetKind::Beckmann, 0.2, 0.4, true);
    assert!(rc.has_smooth() && !rc.has_delta());
    assert_eq!(rc.min_roughness(), 0.2);
    assert_eq!(diffuse(0.5).min_roughness(), f32::INFINITY);
    let p = plastic(0.5, false);
    assert!(p.has_smooth() && p.has_delta());
    assert_eq!(p.min_roughness(), 0.0);
    assert_eq!(
        rough_plastic(MicrofacetKind::Ggx, 0.3, 0.5, false).min_roughness(),
        0.3
    );
    let d = Bsdf::Dielectric(Dielectric {
        eta: ETA,
        specular_reflectance: white(),
        specular_transmittance: white(),
    });
    assert!(!d.has_smooth() && d.has_delta() && d.has_transmission());
    let a = p.albedo(&BsdfContext::default());
    assert!(a.x > 0.5 && a.x <= 1.0);
}

/// The harness is sharp enough to see a wrong distribution family or a wrong roughness.
#[test]
fn chi2_rejects_mismatched_models() {
    let ctx = BsdfContext::default();
    let wi = dir(40.0, 10.0);
    let pairs = [
        (
            rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, true),
            rough_conductor(MicrofacetKind::Beckmann, 0.3, 0.3, true),
        ),
        (
            rough_conductor(MicrofacetKind::Ggx, 0.3, 0.3, true),
            rough_conductor(MicrofacetKind::Ggx, 0.33, 0.33, true),
        ),
        (
            rough_dielectric(MicrofacetKind::Beckmann, 0.3, 0.3, true),
            rough_dielectric(MicrofacetKind::Beckmann, 0.3, 0.36, true),
        ),
    ];
    for (sampler, density) in &pairs {
        let r = chi2_sphere_test(
            |u2, u1| {
                sampler
                    .sample(&ctx, wi, u1, u2)
                    .map(|s| (s.wo, if s.delta { 0.0 } else { 1.0 }))
            },
            |wo| density.pdf(&ctx, wi, wo) as f64,
            Chi2Options {
                samples: 150_000,
                ..Chi2Options::default()
            },
        );
        assert!(!r.passed, "{sampler:?} vs {density:?}: {r}");
    }
}
