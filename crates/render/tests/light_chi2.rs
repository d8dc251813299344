//! Chi-square goodness of fit for light sampling: the directions `Scene::sample_emitter_direction` draws
//! from a shading point against the pdf the integrator uses for MIS (`pdf_emitter_direction_*`), and the
//! returned weights against radiance / pdf.

mod common;

use common::*;
use focal_render::ray::Ray;
use focal_render::scene::LoadedScene;
use focal_testkit::{chi2_sphere_test, Chi2Options, TestRng};
use glam::Vec3;

const SENSOR: &str = r#"<sensor type="perspective"><film type="hdrfilm">
    <integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>"#;

fn scene(body: &str) -> LoadedScene {
    load_str(
        &format!("<scene version=\"3.0.0\">{SENSOR}{body}</scene>"),
        std::path::Path::new("."),
    )
}

/// The MIS pdf of direction `d` from `x`: the first surface along `d` if it is the front of an area light,
/// otherwise the environment's.
fn mis_pdf(s: &LoadedScene, x: Vec3, d: Vec3) -> f64 {
    match s.scene.intersect(&Ray::new(x, d)) {
        Some(si) => {
            let front = si.to_local(-d).z > 0.0;
            if front && s.scene.shapes[si.shape as usize].emitter.is_some() {
                s.scene.pdf_emitter_direction_area(x, &si) as f64
            } else {
                0.0
            }
        }
        None => s.scene.pdf_emitter_direction_env(d) as f64,
    }
}

fn check(name: &str, s: &LoadedScene, x: Vec3, radiance: impl Fn(Vec3) -> Vec3) {
    let mut rng = TestRng::new(0x5eed ^ name.len() as u64);
    let mut checked = 0usize;
    let r = chi2_sphere_test(
        |u2, u1| {
            let u_tri = rng.next_f32();
            let (_, es) = s.scene.sample_emitter_direction(x, u1, u_tri, u2)?;
            assert!(
                es.pdf > 0.0 && es.weight.is_finite(),
                "{name}: bad sample {es:?}"
            );
            // Weight = radiance / pdf, and the sample's pdf is the MIS pdf.
            let expected = radiance(es.wi) / es.pdf;
            assert!(
                (es.weight - expected).abs().max_element() <= 1e-3 * expected.max_element(),
                "{name}: weight"
            );
            let pdf = mis_pdf(s, x, es.wi);
            // At grazing angles on curved lights the re-traced hit point's cosine differs from the
            // sampled one by float error, which the 1/cos of the pdf magnifies; those are left to chi².
            let grazing = es.n != Vec3::ZERO && -es.n.dot(es.wi) < 1e-2;
            if checked < 2000 && !grazing {
                assert!(
                    (pdf - es.pdf as f64).abs() <= 2e-3 * pdf.max(1e-6),
                    "{name}: pdf {} vs {pdf}",
                    es.pdf
                );
                checked += 1;
            }
            Some((es.wi, 1.0))
        },
        |d| mis_pdf(s, x, d),
        Chi2Options {
            samples: 100_000,
            ..Chi2Options::default()
        },
    );
    assert!(r.passed, "{name}: {}", r.message);
}

#[test]
fn mesh_area_light() {
    // A cube-shaped light (12 triangles of two different sizes after non-uniform scaling).
    let s = scene(
        r#"<shape type="cube">
            <transform name="to_world"><scale x="0.3" y="0.1" z="0.6"/><translate y="1.5"/></transform>
            <emitter type="area"><rgb name="radiance" value="2, 3, 4"/></emitter></shape>"#,
    );
    check("cube light", &s, Vec3::new(0.2, 0.0, 0.1), |_| {
        Vec3::new(2.0, 3.0, 4.0)
    });
}

#[test]
fn sphere_light_outside_and_inside() {
    let s = scene(
        r#"<shape type="sphere"><point name="center" x="0" y="2" z="0"/><float name="radius" value="0.5"/>
            <emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>"#,
    );
    check(
        "sphere light from outside",
        &s,
        Vec3::new(0.3, 0.0, 0.0),
        |_| Vec3::splat(5.0),
    );
    let inside = scene(
        r#"<shape type="sphere"><float name="radius" value="2"/><boolean name="flip_normals" value="true"/>
            <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
    );
    check(
        "sphere light from inside",
        &inside,
        Vec3::new(0.3, -0.5, 0.2),
        |_| Vec3::ONE,
    );
}

#[test]
fn disk_light_and_weighted_selection() {
    // Two lights with sampling weights 1 and 3 that never overlap in direction.
    let s = scene(
        r#"<shape type="disk"><transform name="to_world"><scale x="0.5" y="0.25"/><rotate x="1" angle="90"/>
                <translate y="1"/></transform>
            <emitter type="area"><rgb name="radiance" value="1"/><float name="sampling_weight" value="1"/></emitter></shape>
           <shape type="rectangle"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="-90"/>
                <translate y="-1"/></transform>
            <emitter type="area"><rgb name="radiance" value="1"/><float name="sampling_weight" value="3"/></emitter></shape>"#,
    );
    check(
        "disk + rectangle lights",
        &s,
        Vec3::new(0.1, 0.0, 0.0),
        |_| Vec3::ONE,
    );
}

#[test]
fn constant_environment() {
    let s = scene(r#"<emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>"#);
    check("constant", &s, Vec3::ZERO, |_| Vec3::splat(0.5));
}

#[test]
fn cylinder_light_outside_and_inside() {
    // Radius 0.5, length 1.5 along the rotated axis; uniform area sampling of the open tube.
    let s = scene(
        r#"<shape type="cylinder"><float name="radius" value="0.5"/><point name="p1" x="0" y="0" z="1.5"/>
            <transform name="to_world"><rotate x="1" angle="30"/><translate y="1.5"/></transform>
            <emitter type="area"><rgb name="radiance" value="3"/></emitter></shape>"#,
    );
    check(
        "cylinder light from outside",
        &s,
        Vec3::new(0.2, 0.0, 0.3),
        |_| Vec3::splat(3.0),
    );
    let inside = scene(
        r#"<shape type="cylinder"><boolean name="flip_normals" value="true"/>
            <transform name="to_world"><scale x="2" y="2" z="4"/><translate z="-2"/></transform>
            <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
    );
    check(
        "cylinder light from inside",
        &inside,
        Vec3::new(0.3, -0.5, 0.2),
        |_| Vec3::ONE,
    );
}

#[test]
fn envmap_importance_sampling() {
    // A 16×8 map with a bright spot, a black band and a smooth gradient, rotated by to_world.
    let (w, h) = (16u32, 8u32);
    let mut img = focal_render::film::Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = if y == 5 {
                0.0
            } else if (x, y) == (3, 2) {
                40.0
            } else {
                0.2 + 0.1 * x as f32
            };
            img.rgb[(y * w + x) as usize] = [v, 0.5 * v, 0.25 * v + 0.01];
        }
    }
    let path = std::env::temp_dir().join(format!("focal-envmap-{}.exr", std::process::id()));
    img.write_exr(&path).unwrap();
    let s = scene(&format!(
        r#"<emitter type="envmap"><string name="filename" value="{}"/><float name="scale" value="2"/>
            <transform name="to_world"><rotate x="1" angle="90"/><rotate z="1" angle="30"/></transform></emitter>"#,
        path.display()
    ));
    let env = s.scene.environment.expect("environment") as usize;
    let e = s.scene.emitters[env].clone();
    check("envmap", &s, Vec3::ZERO, move |d| e.eval_environment(d));
    // The scale is applied (the spot is interpolated bilinearly, so samples read at most its value).
    let peak = (0..20_000)
        .filter_map(|i| {
            let u = glam::Vec2::new((i % 141) as f32 / 141.0, (i / 141) as f32 / 142.0);
            s.scene.sample_emitter_direction(Vec3::ZERO, 0.5, 0.5, u)
        })
        .map(|(_, es)| (es.weight * es.pdf).x)
        .fold(0.0f32, f32::max);
    assert!(peak <= 80.0 + 1e-3 && peak > 40.0, "{peak}");
    std::fs::remove_file(&path).ok();
}
