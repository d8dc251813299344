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

#[test]
fn white_sphere_under_constant_sky_is_invisible() {
    // A convex white (ρ = 1) diffuse sphere under a uniform sky of radiance 1 reflects exactly 1 everywhere:
    // the image is uniformly 1 (exercises BSDF sampling, environment NEE and their MIS).
    let xml = r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf></shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#;
    let s = load_str(xml, std::path::Path::new("."));
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
