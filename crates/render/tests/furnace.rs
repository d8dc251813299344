//! Furnace tests: closed and open configurations whose radiance is known in closed form.

mod common;

use common::*;

fn mean_of(xml: &str, spp: u32) -> [f64; 3] {
    let s = load_str(xml, std::path::Path::new("."));
    let out = render_loaded(&s, &settings(spp, 7, 0));
    assert!(all_finite(&out.image));
    out.image.mean_rgb()
}

/// A camera inside a closed sphere whose inside emits Le and reflects diffusely with albedo ρ sees
/// L = Le · Σ_{j<d} ρ^j for max_depth d (Le/(1 − ρ) when unlimited). With Le = 0.2, ρ = 0.8: L = 1.
fn closed_sphere(max_depth: i32) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="{max_depth}"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0.1, 0.2, 0.3" target="1, 0.5, -0.2" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="sphere">
        <float name="radius" value="2"/>
        <boolean name="flip_normals" value="true"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="0.2"/></emitter>
    </shape>
</scene>"#
    )
}

#[test]
fn closed_sphere_converges_to_one() {
    let m = mean_of(&closed_sphere(-1), 256);
    for c in m {
        assert!(
            (c - 1.0).abs() < 0.01,
            "closed furnace mean {c}, expected 1"
        );
    }
}

#[test]
fn max_depth_counts_segments_like_mitsuba() {
    // max_depth 0: black; 1: only directly visible emission (0.2); 2: + one bounce; 3: + two bounces.
    let expected = |d: i32| -> f64 { (0..d).map(|j| 0.2 * 0.8f64.powi(j)).sum() };
    for d in 0..=3 {
        let m = mean_of(&closed_sphere(d), 64);
        for c in m {
            assert!(
                (c - expected(d)).abs() < 0.004 + 0.01 * expected(d),
                "max_depth {d}: {c} vs {}",
                expected(d)
            );
        }
    }
}

/// A unit sphere with `bsdf` under a uniform sky of radiance 1, filling the middle of a 16² view.
fn sphere_under_sky(bsdf: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="sphere">{bsdf}</shape>
    {SKY}
</scene>"#
    )
}

#[test]
fn white_sphere_under_constant_sky_is_invisible() {
    // A convex white (ρ = 1) diffuse sphere under a uniform sky of radiance 1 reflects exactly 1 everywhere:
    // the image is uniformly 1 (exercises BSDF sampling, environment NEE and their MIS).
    let xml =
        sphere_under_sky(r#"<bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf>"#);
    let s = load_str(&xml, std::path::Path::new("."));
    let out = render_loaded(&s, &settings(256, 3, 0));
    let worst = out
        .image
        .rgb
        .iter()
        .flatten()
        .map(|c| (c - 1.0).abs())
        .fold(0.0f32, f32::max);
    let m = out.image.mean_rgb();
    eprintln!("mean {m:?}, worst pixel deviation {worst}");
    assert!(m.iter().all(|c| (c - 1.0).abs() < 0.003), "{m:?}");
    assert!(worst < 0.06, "worst pixel deviates by {worst}");
}

#[test]
fn mask_over_plane_under_sky_matches_closed_form() {
    // Camera ray: with probability o the mask's top (ρ_top · 1), else the plane, which sees the sky
    // through the mask (irradiance (1 − o)·π) and the mask's one-sided black underside:
    // L = o·ρ_top + (1 − o)·0.5·(1 − o). Both the shadow rays (through the mask, attenuated) and the
    // BSDF-sampled rays (passing through stochastically) carry the sky, MIS-weighted from the plane.
    for integrator in ["path", "guided"] {
        for (o, top) in [
            (0.5f32, 0.0f32),
            (0.5, 1.0),
            (0.2, 0.0),
            (1.0, 0.0),
            (0.0, 0.0),
        ] {
            let expected = (o * top + (1.0 - o) * 0.5 * (1.0 - o)) as f64;
            let m = mean_of(&masked_plane(o, top, SKY, integrator), 128);
            for c in m {
                assert!(
                    (c - expected).abs() < 0.004 + 0.01 * expected,
                    "{integrator}, opacity {o}, top {top}: mean {c}, expected {expected}"
                );
            }
        }
    }
}

#[test]
fn mask_attenuates_shadow_rays_from_a_point_light() {
    // A point light above the mask reaches the plane only by next-event estimation, through the mask:
    // with opacity 0.5 and a black top, the camera sees (1 − o)² = 1/4 of the unmasked image.
    let light = r#"<emitter type="point"><point name="position" x="0" y="0" z="1"/><rgb name="intensity" value="1"/></emitter>"#;
    let open = mean_of(&masked_plane(0.0, 0.0, light, "path"), 64);
    let masked = mean_of(&masked_plane(0.5, 0.0, light, "path"), 64);
    for (a, b) in open.iter().zip(masked) {
        assert!(*a > 0.01, "{a}");
        assert!((b / a - 0.25).abs() < 0.01, "ratio {}", b / a);
    }
}

#[test]
fn difftrans_sphere_under_constant_sky_is_invisible() {
    // A lossless diffuse transmitter (T = 1) closed into a sphere under a uniform sky of radiance 1:
    // every ray leaves with radiance 1, however often it crosses the shell.
    let xml = |t: &str| {
        sphere_under_sky(&format!(
            r#"<bsdf type="difftrans"><rgb name="transmittance" value="{t}"/></bsdf>"#
        ))
    };
    let m = mean_of(&xml("1"), 128);
    assert!(m.iter().all(|c| (c - 1.0).abs() < 0.005), "{m:?}");
    // T = 0.5 loses energy at every crossing: the shell is darker than the sky around it.
    let half = mean_of(&xml("0.5"), 32);
    assert!(half.iter().all(|c| *c > 0.3 && *c < 0.95), "{half:?}");
}

#[test]
fn diffuse_plane_under_an_envmap_matches_its_irradiance() {
    // A map with bright texels next to black ones, where bilinear radiance and the cell-wise sampling
    // density differ most; the plane's radiance ρ/π·∫L cos θ dω is integrated numerically from the same
    // (bilinear) lookup. Exercises environment NEE and BSDF sampling with their MIS.
    let (w, h) = (12u32, 6u32);
    let mut img = focal_render::film::Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = match (x, y) {
                (4, 1) => 30.0,
                (9, 2) => 12.0,
                (_, 0) | (_, 3) => 0.0,
                _ => 0.3 + 0.05 * x as f32,
            };
            img.rgb[(y * w + x) as usize] = [v, 0.6 * v, 0.2 * v];
        }
    }
    let path = std::env::temp_dir().join(format!("focal-furnace-env-{}.exr", std::process::id()));
    img.write_exr(&path).unwrap();
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="10"/>
        <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="1000"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>
    </shape>
    <emitter type="envmap"><string name="filename" value="{}"/>
        <transform name="to_world"><rotate y="1" angle="20"/></transform></emitter>
</scene>"#,
        path.display()
    );
    let s = load_str(&xml, std::path::Path::new("."));
    std::fs::remove_file(&path).ok();
    let env = &s.scene.emitters[s.scene.environment.unwrap() as usize];
    let (nt, np) = (1024usize, 2048usize);
    let mut e = glam::DVec3::ZERO;
    for i in 0..nt {
        let theta = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
        for j in 0..np {
            let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
            let d = glam::DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            let l = env.eval_environment(d.as_vec3()).as_dvec3();
            e += l * theta.cos() * theta.sin();
        }
    }
    e *= std::f64::consts::FRAC_PI_2 / nt as f64 * std::f64::consts::TAU / np as f64;
    let expected = e * 0.8 / std::f64::consts::PI;
    let out = render_loaded(&s, &settings(512, 5, 0));
    assert!(all_finite(&out.image));
    let m = out.image.mean_rgb();
    eprintln!("rendered {m:?}, integrated {expected:?}");
    for c in 0..3 {
        assert!(
            (m[c] - expected[c]).abs() < 0.01 * expected[c],
            "channel {c}: rendered {} vs integrated {}",
            m[c],
            expected[c]
        );
    }
}
