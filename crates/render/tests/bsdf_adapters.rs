//! The BSDFs that wrap other BSDFs in Mitsuba 0.6 scenes (`mixturebsdf`, `bumpmap`, `coating`, `roughcoating`): their
//! reading from XML, chi-square tests of their sampling, consistency of weights with eval/pdf and
//! white-furnace bounds (common/bsdf_check.rs), and closed-form checks. The bump map is compared with
//! Mitsuba 3 in bumpmap_render.rs.

mod common;

use common::bsdf_check::{check_case, Case, Energy};
use common::*;
use focal_render::bsdf::fresnel::fresnel_dielectric;
use focal_render::bsdf::{
    shadow_terminator, Bsdf, BsdfContext, BumpMap, Coating, CoatingLayer, Conductor, Dielectric,
    Diffuse, Microfacet, MicrofacetKind, Mixture, NormalMap, Plastic, RoughCoating, RoughConductor,
};
use focal_render::color::Rgb;
use focal_render::texture::{Bitmap, BitmapFilter, Texture, UvTransform, WrapMode};
use focal_testkit::TestRng;
use glam::{Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

fn diffuse(r: f32) -> Bsdf {
    Bsdf::Diffuse(Diffuse {
        reflectance: Texture::constant(r),
    })
}

fn rough_conductor(alpha: f32) -> Bsdf {
    Bsdf::RoughConductor(Box::new(RoughConductor {
        distribution: Microfacet::new(MicrofacetKind::Ggx, alpha, alpha, true),
        eta: Texture::Constant(Rgb::ZERO),
        k: Texture::Constant(Rgb::ONE),
        specular_reflectance: Texture::constant(1.0),
    }))
}

fn plastic() -> Bsdf {
    Bsdf::Plastic(Box::new(Plastic::new(
        1.5,
        Texture::constant(1.0),
        None,
        false,
    )))
}

fn glass() -> Bsdf {
    Bsdf::Dielectric(Dielectric {
        eta: 1.5,
        specular_reflectance: Texture::constant(1.0),
        specular_transmittance: Texture::constant(1.0),
    })
}

/// A height field rising linearly along u: two texels 0 and 1, bilinear and clamped, so that
/// ∂h/∂u = 2 and ∂h/∂v = 0 between u = 0.25 and 0.75.
fn ramp() -> Texture {
    Texture::Bitmap(Arc::new(
        Bitmap::new(
            2,
            1,
            vec![Rgb::ZERO, Rgb::ONE],
            BitmapFilter::Bilinear,
            [WrapMode::Clamp; 2],
            UvTransform::IDENTITY,
        )
        .unwrap(),
    ))
}

fn bumpmap(nested: Bsdf, scale: f32) -> Bsdf {
    bumpmap_shadowed(nested, scale, false)
}

fn bumpmap_shadowed(nested: Bsdf, scale: f32, shadowing: bool) -> Bsdf {
    Bsdf::BumpMap(Box::new(BumpMap {
        nested,
        height: ramp(),
        scale,
        shadowing,
    }))
}

/// A query at uv (0.5, 0.5) with the given surface derivatives (local frame).
fn bump_ctx(dp_du: Vec3, dp_dv: Vec3) -> BsdfContext {
    let mut ctx = BsdfContext::at_uv(Vec2::new(0.5, 0.5));
    ctx.dp_du = dp_du;
    ctx.dp_dv = dp_dv;
    ctx
}

/// The ramp's scale that tilts the normal by `deg` degrees on a unit square patch.
fn tilt_scale(deg: f32) -> f32 {
    deg.to_radians().tan() / 2.0
}

/// A layer of relative IOR `eta`, thickness 1 and absorption `sigma_a`.
fn layer(eta: f32, sigma_a: f32) -> CoatingLayer {
    CoatingLayer::new(eta, 1.0, Texture::constant(sigma_a), Texture::constant(1.0))
}

fn coating(nested: Bsdf, eta: f32, sigma_a: f32) -> Bsdf {
    Bsdf::Coating(Box::new(Coating::new(nested, layer(eta, sigma_a))))
}

fn rough_coating(nested: Bsdf, kind: MicrofacetKind, alpha: f32, eta: f32, sigma_a: f32) -> Bsdf {
    Bsdf::RoughCoating(Box::new(RoughCoating::new(
        nested,
        Microfacet::new(kind, alpha, alpha, true),
        layer(eta, sigma_a),
    )))
}

fn mirror() -> Bsdf {
    Bsdf::Conductor(Box::new(Conductor {
        eta: Texture::Constant(Rgb::ZERO),
        k: Texture::Constant(Rgb::ONE),
        specular_reflectance: Texture::constant(1.0),
    }))
}

fn mixture(parts: Vec<(Bsdf, f32)>) -> Bsdf {
    let (bsdfs, weights) = parts.into_iter().unzip();
    Bsdf::Mixture(Box::new(
        Mixture::new(bsdfs, weights).expect("valid mixture"),
    ))
}

/// Every case of this file with the context it is queried at.
fn cases() -> Vec<(Case, BsdfContext)> {
    let mut out = Vec::new();
    let front = [dir(0.0, 0.0), dir(45.0, 30.0), dir(80.0, 200.0)];
    let mut add = |name: &str, bsdf: Bsdf, wis: &[Vec3], energy: Energy, ctx: BsdfContext| {
        for (i, wi) in wis.iter().enumerate() {
            out.push((
                Case {
                    name: format!("{name} wi#{i}"),
                    bsdf: bsdf.clone(),
                    wi: *wi,
                    energy,
                },
                ctx,
            ));
        }
    };
    let ctx = BsdfContext::default();
    // Lossless lobes with weights summing to one: a lossless mixture.
    add(
        "mixturebsdf diffuse|diffuse",
        mixture(vec![(diffuse(1.0), 0.25), (diffuse(1.0), 0.75)]),
        &front,
        Energy::One,
        ctx,
    );
    add(
        "mixturebsdf diffuse|dielectric",
        mixture(vec![(diffuse(1.0), 0.6), (glass(), 0.4)]),
        &front,
        Energy::One,
        ctx,
    );
    add(
        "mixturebsdf diffuse|roughconductor|plastic",
        mixture(vec![
            (diffuse(1.0), 0.3),
            (rough_conductor(0.2), 0.3),
            (plastic(), 0.4),
        ]),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    // Weights summing to less than one absorb the rest; a zero weight is never sampled.
    add(
        "mixturebsdf partial",
        mixture(vec![
            (rough_conductor(0.5), 0.2),
            (diffuse(1.0), 0.0),
            (diffuse(1.0), 0.3),
        ]),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    // Bump maps tilt the nested model's frame by 35°; directions on different sides of the two normals
    // are masked, so energy can only be lost.
    let unit = bump_ctx(Vec3::X, Vec3::Y);
    let skewed = bump_ctx(Vec3::new(2.0, 0.3, 0.1), Vec3::new(-0.2, 1.5, 0.05));
    let bump_wis = [dir(0.0, 0.0), dir(60.0, 0.0), dir(70.0, 180.0)];
    add(
        "bumpmap diffuse",
        bumpmap(diffuse(1.0), tilt_scale(35.0)),
        &bump_wis,
        Energy::AtMostOne,
        unit,
    );
    add(
        "bumpmap roughconductor skewed",
        bumpmap(rough_conductor(0.2), tilt_scale(35.0)),
        &bump_wis,
        Energy::AtMostOne,
        skewed,
    );
    add(
        "bumpmap shadowed diffuse",
        bumpmap_shadowed(diffuse(1.0), tilt_scale(35.0), true),
        &bump_wis,
        Energy::AtMostOne,
        skewed,
    );
    add(
        "bumpmap mixturebsdf",
        bumpmap(
            mixture(vec![(diffuse(1.0), 0.5), (rough_conductor(0.3), 0.5)]),
            -tilt_scale(20.0),
        ),
        &bump_wis,
        Energy::AtMostOne,
        skewed,
    );
    // Coatings lose the internally reflected light (Mitsuba 0.6), so energy can only be lost; the
    // interface reflects on both sides.
    let both = [
        dir(0.0, 0.0),
        dir(50.0, 30.0),
        dir(85.0, 200.0),
        dir(120.0, 40.0),
    ];
    add(
        "coating diffuse",
        coating(diffuse(1.0), 1.5, 0.0),
        &both,
        Energy::AtMostOne,
        ctx,
    );
    add(
        "coating roughconductor absorbing",
        coating(rough_conductor(0.2), 1.7, 0.3),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    add(
        "coating plastic",
        coating(plastic(), 1.3, 0.0),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    add(
        "coating diffuse eta<1",
        coating(diffuse(1.0), 1.0 / 1.4, 0.0),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    add(
        "roughcoating diffuse",
        rough_coating(diffuse(1.0), MicrofacetKind::Beckmann, 0.2, 1.5, 0.0),
        &both,
        Energy::AtMostOne,
        ctx,
    );
    add(
        "roughcoating roughconductor absorbing",
        rough_coating(rough_conductor(0.3), MicrofacetKind::Ggx, 0.4, 1.6, 0.5),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    add(
        "roughcoating mirror",
        rough_coating(mirror(), MicrofacetKind::Ggx, 0.1, 1.5, 0.2),
        &front,
        Energy::AtMostOne,
        ctx,
    );
    out
}

/// Runs the cases whose name starts with one of `prefixes`; the Šidák correction counts every case.
fn check_cases(prefixes: &[&str]) {
    let all = cases();
    let num_tests = all.len();
    let mut failures = Vec::new();
    let mut n = 0;
    for (case, ctx) in all
        .iter()
        .filter(|(c, _)| prefixes.iter().any(|p| c.name.starts_with(p)))
    {
        n += 1;
        failures.extend(check_case(case, ctx, num_tests));
    }
    assert!(n > 0);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn chi2_mixturebsdf() {
    check_cases(&["mixturebsdf"]);
}

#[test]
fn chi2_bumpmap() {
    check_cases(&["bumpmap"]);
}

#[test]
fn chi2_coating() {
    check_cases(&["coating"]);
}

#[test]
fn chi2_roughcoating() {
    check_cases(&["roughcoating"]);
}

/// A nearly smooth rough coating reflects what the smooth coating does; rougher ones stay below one.
#[test]
fn roughcoating_tends_to_the_smooth_coating() {
    for theta in [0.0f32, 45.0, 70.0] {
        let wi = dir(theta, 10.0);
        let smooth = albedo(&coating(diffuse(1.0), 1.5, 0.0), wi, 21);
        let rough = albedo(
            &rough_coating(diffuse(1.0), MicrofacetKind::Ggx, 0.005, 1.5, 0.0),
            wi,
            22,
        );
        assert!(
            (smooth - rough).abs() < 0.01,
            "θ {theta}: {smooth} vs {rough}"
        );
    }
}

/// On a unit square patch, a height rising along u with slope 2·scale tilts the normal towards −u by
/// atan(2·scale): the bump map is the normal map of that normal.
#[test]
fn bumpmap_is_the_normal_map_of_the_height_gradient() {
    let s = 0.4f32;
    let n = Vec3::new(-2.0 * s, 0.0, 1.0).normalize();
    let ctx = bump_ctx(Vec3::X, Vec3::Y);
    let bump = bumpmap(diffuse(0.7), s);
    let normal = Bsdf::NormalMap(Box::new(NormalMap {
        nested: diffuse(0.7),
        normals: Texture::Constant((n + Vec3::ONE) * 0.5),
    }));
    let Bsdf::BumpMap(b) = &bump else { panic!() };
    assert!(
        (b.frame(&ctx).n - n).length() < 1e-6,
        "{:?}",
        b.frame(&ctx).n
    );
    let mut rng = TestRng::new(11);
    for _ in 0..200 {
        let wi = focal_render::warp::square_to_cosine_hemisphere(Vec2::new(
            rng.next_f32(),
            rng.next_f32(),
        ));
        let wo = focal_render::warp::square_to_cosine_hemisphere(Vec2::new(
            rng.next_f32(),
            rng.next_f32(),
        ));
        let (a, b) = (bump.eval(&ctx, wi, wo), normal.eval(&ctx, wi, wo));
        assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}");
        assert!((bump.pdf(&ctx, wi, wo) - normal.pdf(&ctx, wi, wo)).abs() < 1e-4);
    }
    // Longer tangents (a larger surface per unit of uv) flatten the same height field.
    let (wi, wo) = (dir(10.0, 0.0), dir(60.0, 180.0));
    let stretched = bump_ctx(Vec3::X * 4.0, Vec3::Y * 4.0);
    let flat = BsdfContext::at_uv(Vec2::new(0.5, 0.5));
    let f_flat = diffuse(0.7).eval(&flat, wi, wo).x;
    let f_unit = bump.eval(&ctx, wi, wo).x;
    let f_stretched = bump.eval(&stretched, wi, wo).x;
    assert!(
        (f_stretched - f_flat).abs() < (f_unit - f_flat).abs() / 2.0,
        "{f_flat} {f_unit} {f_stretched}"
    );
    // Mitsuba 3's shadowing term, at a normal and direction where Mitsuba 3.9's bumpmap evaluates
    // 0.199707 with it and 0.206702 without (tools/mitsuba3_bumpmap.py's height field at uv (0.51, 0.77)).
    let g = Vec2::new(-7.970_44, -2.143_43) * 0.15;
    let n = Vec3::new(-2.0 * g.x, -2.0 * g.y, 4.0).normalize();
    let g_m3 = shadow_terminator(n, Vec3::new(1.0, -0.3, 0.6).normalize());
    assert!((g_m3 - 0.199707 / 0.206702).abs() < 1e-4, "{g_m3}");
    assert_eq!(shadow_terminator(Vec3::Z, dir(80.0, 0.0)), 1.0);
    // Without surface derivatives (e.g. a shadow-ray query) the frame is not perturbed.
    assert_eq!(bump.eval(&flat, wi, wo), f_flat * Vec3::ONE);
    assert!(bump.has_smooth() && !bump.has_delta());
}

/// 2∫₀¹ F(μ) μ dμ for light leaving a medium of relative IOR `eta` (midpoint rule).
fn internal_diffuse_reflectance(eta: f32) -> f64 {
    let n = 20_000;
    (0..n)
        .map(|i| {
            let mu = (i as f64 + 0.5) / n as f64;
            2.0 * fresnel_dielectric(mu as f32, 1.0 / eta).f as f64 * mu / n as f64
        })
        .sum()
}

/// A coated white diffuse base reflects F(θ) at the interface plus (1 − F(θ))·(1 − F_dr,int): the
/// light that enters, scatters diffusely and escapes (what reflects back inside is lost).
#[test]
fn coated_white_diffuse_albedo_matches_closed_form() {
    for (eta, theta) in [(1.5f32, 0.0f32), (1.5, 60.0), (1.33, 30.0)] {
        let wi = dir(theta, 0.0);
        let r = fresnel_dielectric(wi.z, eta).f as f64;
        let expected = r + (1.0 - r) * (1.0 - internal_diffuse_reflectance(eta));
        let a = albedo(&coating(diffuse(1.0), eta, 0.0), wi, 5);
        assert!(
            (a - expected).abs() < 0.004,
            "η {eta}, θ {theta}: {a} vs {expected}"
        );
    }
}

/// A coated mirror with absorption σₐ·d: F + (1 − F)²·exp(−2σₐd / cos θ'), θ' the refracted angle.
#[test]
fn coated_mirror_absorbs_along_the_refracted_path() {
    for (sigma, theta) in [(0.0f32, 0.0f32), (0.4, 0.0), (0.4, 50.0), (1.5, 70.0)] {
        let eta = 1.5;
        let wi = dir(theta, 30.0);
        let r = fresnel_dielectric(wi.z, eta).f as f64;
        let sin_t = theta.to_radians().sin() / eta;
        let cos_t = (1.0 - sin_t * sin_t).sqrt() as f64;
        let expected = r + (1.0 - r).powi(2) * (-2.0 * sigma as f64 / cos_t).exp();
        let a = albedo(&coating(mirror(), eta, sigma), wi, 9);
        assert!(
            (a - expected).abs() < 0.003,
            "σ {sigma}, θ {theta}: {a} vs {expected}"
        );
    }
}

/// The white-furnace albedo of a mixture is the weighted sum of its components' albedos.
fn albedo(b: &Bsdf, wi: Vec3, seed: u64) -> f64 {
    let ctx = BsdfContext::default();
    let mut rng = TestRng::new(seed);
    let n = 200_000;
    let mut sum = 0.0f64;
    for _ in 0..n {
        let u2 = Vec2::new(rng.next_f32(), rng.next_f32());
        if let Some(s) = b.sample(&ctx, wi, rng.next_f32(), u2) {
            sum += s.weight.x as f64;
        }
    }
    sum / n as f64
}

#[test]
fn mixture_albedo_is_the_weighted_sum() {
    let wi = dir(30.0, 0.0);
    let rc = rough_conductor(0.3);
    let (a_d, a_rc) = (albedo(&diffuse(0.8), wi, 1), albedo(&rc, wi, 2));
    let m = mixture(vec![(diffuse(0.8), 0.2), (rc, 0.5)]);
    let a_m = albedo(&m, wi, 3);
    let expected = 0.2 * a_d + 0.5 * a_rc;
    assert!((a_m - expected).abs() < 0.01, "{a_m} vs {expected}");
}

#[test]
fn mixture_eval_and_pdf_are_weighted_sums() {
    let ctx = BsdfContext::default();
    let (a, b) = (diffuse(0.8), rough_conductor(0.3));
    let m = mixture(vec![(a.clone(), 0.1), (b.clone(), 0.3)]);
    let (wi, wo) = (dir(20.0, 10.0), dir(25.0, 185.0));
    let f = m.eval(&ctx, wi, wo);
    let f_expected = a.eval(&ctx, wi, wo) * 0.1 + b.eval(&ctx, wi, wo) * 0.3;
    assert!(
        (f - f_expected).abs().max_element() < 1e-6,
        "{f} vs {f_expected}"
    );
    // Components are picked in proportion to their weights: 1/4 and 3/4.
    let p = m.pdf(&ctx, wi, wo);
    let p_expected = a.pdf(&ctx, wi, wo) * 0.25 + b.pdf(&ctx, wi, wo) * 0.75;
    assert!(
        (p - p_expected).abs() < 1e-5 * p_expected,
        "{p} vs {p_expected}"
    );
    assert!(m.has_smooth() && !m.has_delta() && !m.has_transmission());
    assert_eq!(m.min_roughness(), 0.3);
    // A delta component keeps its weight w_i/p_i and its pdf is the selection probability.
    let g = mixture(vec![(diffuse(1.0), 0.3), (glass(), 0.3)]);
    let s = g.sample(&ctx, wi, 0.9, Vec2::new(0.5, 0.5)).unwrap();
    let alone = glass().sample(&ctx, wi, 0.8, Vec2::new(0.5, 0.5)).unwrap();
    assert!(s.delta && (s.wo - alone.wo).length() < 1e-6);
    assert!((s.pdf - 0.5 * alone.pdf).abs() < 1e-6, "{s:?}");
    assert!(
        (s.weight - alone.weight * 0.6).abs().max_element() < 1e-6,
        "{s:?}"
    );
    assert!(g.has_delta() && g.has_transmission());
}

/// A Mitsuba 0.6 scene with one sphere of material `bsdf`.
fn sphere_scene(bsdf: &str) -> String {
    format!(
        r#"<scene version="0.6.0">
    <sensor type="perspective">
        <transform name="toWorld"><lookAt origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <emitter type="constant"/>
    <shape type="sphere">
{bsdf}
    </shape>
</scene>"#
    )
}

fn try_load(
    xml: &str,
) -> Result<focal_render::scene::LoadedScene, focal_render::error::SceneError> {
    let desc = focal_render::desc::xml::parse_scene_str(xml, Path::new("inline.xml"), &[])?;
    focal_render::scene::build_scene(&desc, &Default::default())
}

#[test]
fn mixturebsdf_is_read_from_mitsuba06_xml() {
    let s = try_load(&sphere_scene(
        r#"        <bsdf type="mixturebsdf">
            <string name="weights" value="0.2; 0.3 0.4"/>
            <bsdf type="diffuse"/>
            <bsdf type="roughconductor"><string name="material" value="Cu"/></bsdf>
            <bsdf type="plastic"/>
        </bsdf>"#,
    ))
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Bsdf::Mixture(m) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!("a mixture")
    };
    assert_eq!(m.weights(), &[0.2, 0.3, 0.4]);
    assert_eq!(m.bsdfs.len(), 3);
    assert!(matches!(m.bsdfs[1], Bsdf::RoughConductor(_)));

    // Weights over one are normalised with a warning, unless ensureEnergyConservation is false.
    let over = |extra: &str| {
        sphere_scene(&format!(
            r#"        <bsdf type="mixturebsdf">
            <string name="weights" value="1, 3"/>{extra}
            <bsdf type="diffuse"/>
            <bsdf type="diffuse"/>
        </bsdf>"#
        ))
    };
    let s = try_load(&over("")).unwrap();
    let Bsdf::Mixture(m) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!()
    };
    assert_eq!(m.weights(), &[0.25, 0.75]);
    assert!(
        s.warnings.len() == 1 && s.warnings[0].contains("inline.xml:9"),
        "{:?}",
        s.warnings
    );
    let s = try_load(&over(
        r#"<boolean name="ensureEnergyConservation" value="false"/>"#,
    ))
    .unwrap();
    let Bsdf::Mixture(m) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!()
    };
    assert_eq!(m.weights(), &[1.0, 3.0]);
    assert!(s.warnings.is_empty());
}

#[test]
fn mixturebsdf_mistakes_are_located_errors() {
    for (weights, needle) in [
        (
            r#"<string name="weights" value="0.5"/>"#,
            "2 nested BSDFs but 1 weights",
        ),
        (r#"<string name="weights" value="0.5, x"/>"#, "'x'"),
        (
            r#"<string name="weights" value="0.5, -0.1"/>"#,
            "non-negative",
        ),
        (r#"<string name="weights" value="0, 0"/>"#, "all be zero"),
        ("", "needs 'weights'"),
    ] {
        let xml = sphere_scene(&format!(
            r#"        <bsdf type="mixturebsdf">
            {weights}
            <bsdf type="diffuse"/>
            <bsdf type="diffuse"/>
        </bsdf>"#
        ));
        let e = try_load(&xml).err().expect("an error");
        assert!(e.message.contains(needle), "{weights}: {e}");
        let line = e.loc.expect("located").line;
        assert!(line == 8 || line == 9, "{weights}: line {line}");
    }
}

#[test]
fn coatings_are_read_from_mitsuba06_xml() {
    let s = try_load(&sphere_scene(
        r#"        <bsdf type="coating">
            <float name="intIOR" value="1.7"/>
            <float name="thickness" value="2"/>
            <rgb name="sigmaA" value="0.1, 0.2, 0.3"/>
            <bsdf type="roughconductor"><string name="material" value="Cu"/></bsdf>
        </bsdf>"#,
    ))
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Bsdf::Coating(c) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!("a coating")
    };
    assert!((c.layer.eta - 1.7 / 1.000277).abs() < 1e-5 && c.layer.thickness == 2.0);
    assert_eq!(c.layer.sigma_a.eval(Vec2::ZERO), Vec3::new(0.1, 0.2, 0.3));
    assert!(matches!(c.nested, Bsdf::RoughConductor(_)));

    let s = try_load(&sphere_scene(
        r#"        <bsdf type="roughcoating">
            <string name="distribution" value="GGX"/>
            <float name="alpha" value="0.3"/>
            <bsdf type="diffuse"/>
        </bsdf>"#,
    ))
    .unwrap();
    let Bsdf::RoughCoating(c) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!("a rough coating")
    };
    assert_eq!(c.distribution.kind, MicrofacetKind::Ggx);
    assert_eq!(c.distribution.alpha_u, 0.3);
    assert!((c.layer.eta - 1.5046 / 1.000277).abs() < 1e-5);

    for (inner, needle, line) in [
        (r#"<bsdf type="dielectric"/>"#, "transmissive", 9),
        (
            r#"<float name="thickness" value="-1"/><bsdf type="diffuse"/>"#,
            "thickness",
            9,
        ),
        ("", "exactly one nested BSDF", 8),
        (
            r#"<float name="intIOR" value="1"/><float name="extIOR" value="1"/><bsdf type="diffuse"/>"#,
            "must differ",
            9,
        ),
    ] {
        for plugin in ["coating", "roughcoating"] {
            let xml = sphere_scene(&format!(
                "        <bsdf type=\"{plugin}\">\n            {inner}\n        </bsdf>"
            ));
            let e = try_load(&xml).err().expect("an error");
            assert!(e.message.contains(needle), "{plugin} {inner}: {e}");
            assert_eq!(
                e.loc.as_ref().expect("located").line,
                line,
                "{plugin} {inner}: {e}"
            );
        }
    }
}

#[test]
fn bumpmap_is_read_from_mitsuba06_and_mitsuba3_xml() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/bumpmap");
    let load_version = |bsdf: &str, version: &str| {
        let xml = sphere_scene(bsdf)
            .replace("0.6.0", version)
            .replace("toWorld", "to_world")
            .replace("lookAt", "lookat");
        let desc = focal_render::desc::xml::parse_scene_str(&xml, &dir.join("inline.xml"), &[])?;
        focal_render::scene::build_scene(&desc, &Default::default())
    };
    let load_in = |bsdf: &str| load_version(bsdf, "0.6.0");
    // Mitsuba 3: any texture name and `scale`.
    let s = load_version(
        r#"        <bsdf type="bumpmap">
            <texture type="bitmap" name="arbitrary"><string name="filename" value="height.exr"/></texture>
            <float name="scale" value="0.5"/>
            <bsdf type="roughplastic"/>
        </bsdf>"#,
        "3.0.0",
    )
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Bsdf::BumpMap(b) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!("a bump map")
    };
    assert_eq!(b.scale, 0.5);
    assert!(matches!(b.height, Texture::Bitmap(_)) && matches!(b.nested, Bsdf::RoughPlastic(_)));
    assert!(b.shadowing, "Mitsuba 3's default");
    // Mitsuba 0.6: the height scaled by a `scale` texture.
    let s = load_in(
        r#"        <bsdf type="bumpmap">
            <texture type="scale">
                <float name="scale" value="0.25"/>
                <texture type="bitmap"><string name="filename" value="height.exr"/></texture>
            </texture>
            <bsdf type="diffuse"/>
        </bsdf>"#,
    )
    .unwrap();
    let Bsdf::BumpMap(b) = &s.scene.bsdfs[s.scene.shapes[0].bsdf as usize] else {
        panic!("a bump map")
    };
    assert_eq!(b.scale, 0.25);
    assert!(!b.shadowing, "Mitsuba 0.6 has no shadowing term");
    for (inner, needle) in [
        (r#"<bsdf type="diffuse"/>"#, "nested texture"),
        (
            r#"<texture type="bitmap"><string name="filename" value="height.exr"/></texture>"#,
            "nested BSDF",
        ),
    ] {
        let e = load_in(&format!(
            "        <bsdf type=\"bumpmap\">\n            {inner}\n        </bsdf>"
        ))
        .err()
        .expect("an error");
        assert!(e.message.contains(needle), "{inner}: {e}");
        assert_eq!(e.loc.as_ref().expect("located").line, 8, "{e}");
    }
}

/// A convex sphere under a uniform sky of radiance 1 whose material is a lossless mixture (a white
/// diffuse and a perfect mirror, weights summing to one) reflects exactly 1 everywhere: the renderer's
/// MIS and delta handling see the mixture as one consistent BSDF (white furnace).
#[test]
fn lossless_mixture_sphere_under_constant_sky_is_invisible() {
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="sphere">
        <bsdf type="mixturebsdf">
            <string name="weights" value="0.35, 0.65"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf>
            <bsdf type="conductor"/>
        </bsdf>
    </shape>
    {SKY}
</scene>"#
    );
    let s = load_str(&xml, Path::new("."));
    let out = render_loaded(&s, &settings(128, 3, 0));
    let m = out.image.mean_rgb();
    assert!(m.iter().all(|c| (c - 1.0).abs() < 0.005), "{m:?}");
}
