//! Every scene of the vendored corpus (public Mitsuba scenes in `tests/data/corpus`) loads and renders a
//! few samples of a small film crop without NaN and with a plausible mean, or fails early with the
//! documented, located error.

mod common;

use common::*;
use focal_render::load::load_scene;
use focal_render::scene::{BuildOptions, LoadedScene, Strictness};

fn load_corpus(rel: &str, opts: &BuildOptions) -> Result<LoadedScene, String> {
    let path = test_data_dir().join("corpus").join(rel);
    load_scene(&path, &[], opts).map_err(|e| e.to_string())
}

fn render_corpus_with(rel: &str, opts: &BuildOptions) -> (LoadedScene, [f64; 3]) {
    let mut s = load_corpus(rel, opts).unwrap_or_else(|e| panic!("{e}"));
    // A small crop of the film keeps this fast in debug builds.
    s.film.crop_size = s.film.crop_size.min(glam::UVec2::new(96, 72));
    let out = render_loaded(&s, &settings(4, 5, 0));
    assert!(all_finite(&out.image), "{rel}: non-finite pixels");
    let m = out.image.mean_rgb();
    assert!(
        m.iter().all(|c| *c > 1e-4 && *c < 1e3),
        "{rel}: implausible mean {m:?}"
    );
    (s, m)
}

fn render_corpus(rel: &str, integrator: Option<&str>) -> [f64; 3] {
    let opts = BuildOptions {
        integrator_override: integrator.map(str::to_string),
        ..Default::default()
    };
    render_corpus_with(rel, &opts).1
}

#[test]
fn cbox_mitsuba3_renders() {
    render_corpus("cbox-mi3/cbox.xml", None);
}

#[test]
fn cbox_mitsuba05_guided_path_renders_as_path_with_a_warning() {
    let (s, _) = render_corpus_with("cbox-mi05/cbox.xml", &BuildOptions::default());
    let w = s.warnings.join("\n");
    assert!(
        w.contains("guided_path") && w.contains("cbox.xml:8:") && w.contains("'path'"),
        "{w}"
    );
    // Its maxDepth 10 / rrDepth 10 are kept.
    let focal_render::scene::IntegratorSpec::Path(p) = &s.integrator else {
        panic!("expected the path tracer")
    };
    assert_eq!((p.max_depth, p.rr_depth), (10, 10));
}

#[test]
fn sms_ring_specular_manifold_integrator_renders_as_path_with_a_warning() {
    let s = load_corpus("sms-ring/ring.xml", &BuildOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let w = s.warnings.join("\n");
    assert!(
        w.contains("path_sms_ss") && w.contains("ring.xml:6:") && w.contains("'path'"),
        "{w}"
    );
}

#[test]
fn every_corpus_scene_loads_strictly_except_media_and_sunsky() {
    let corpus = test_data_dir().join("corpus");
    let mut checked = 0;
    for entry in std::fs::read_dir(&corpus).unwrap() {
        let dir = entry.unwrap().path();
        let Ok(files) = std::fs::read_dir(&dir) else {
            continue;
        };
        for f in files {
            let f = f.unwrap().path();
            if f.extension().is_none_or(|e| e != "xml") {
                continue;
            }
            let rel = f
                .strip_prefix(&corpus)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let result = load_corpus(&rel, &BuildOptions::default());
            match rel.as_str() {
                // Participating media are not supported; Mitsuba 0.6's sunsky is an error (see
                // docs/plugins.md).
                "glass-of-milk/scene.xml" | "torus-v06/scene.xml" => {
                    assert!(result.is_err(), "{rel} was expected to fail")
                }
                _ => {
                    if let Err(e) = result {
                        panic!("{rel}: {e}");
                    }
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 9, "only {checked} corpus scenes found");
}

#[test]
fn unknown_integrators_stay_errors() {
    let xml = r#"<scene version="3.0.0"><integrator type="bdpt"/>
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
            <integer name="height" value="4"/></film></sensor></scene>"#;
    let desc =
        focal_render::desc::xml::parse_scene_str(xml, std::path::Path::new("s.xml"), &[]).unwrap();
    let e = focal_render::scene::build_scene(&desc, &BuildOptions::default())
        .err()
        .expect("bdpt is not ours");
    assert!(
        e.to_string().contains("bdpt") && e.to_string().contains("s.xml:1:"),
        "{e}"
    );
}

#[test]
fn veach_mis_renders() {
    render_corpus("veach-mis-mi3/integrator_direct_both.xml", None);
}

#[test]
fn veach_bidir_renders() {
    let (s, _) = render_corpus_with("veach-bidir/scene.xml", &BuildOptions::default());
    assert!(s
        .warnings
        .iter()
        .any(|w| w.contains("path_guiding_integrator")));
    let focal_render::scene::IntegratorSpec::Path(p) = &s.integrator else {
        panic!("expected the path tracer")
    };
    assert_eq!(p.max_depth, 7);
}

#[test]
fn torus_mitsuba3_serialized_renders() {
    let (s, _) = render_corpus_with("torus-v3/scene.xml", &BuildOptions::default());
    // Five meshes from one serialized file.
    assert_eq!(s.scene.geometries.len(), 5);
    let focal_render::scene::IntegratorSpec::Path(p) = &s.integrator else {
        panic!("expected the path tracer")
    };
    assert_eq!((p.max_depth, p.rr_depth), (30, 8));
}

#[test]
fn torus_mitsuba06_sunsky_is_a_clear_error_and_renders_leniently() {
    let e = load_corpus("torus-v06/scene.xml", &BuildOptions::default())
        .err()
        .expect("sunsky is not implemented");
    assert!(
        e.contains("sunsky") && e.contains("scene.xml:32:") && e.contains("--lenient"),
        "{e}"
    );
    let opts = BuildOptions {
        strictness: Strictness::Lenient,
        ..Default::default()
    };
    let (s, _) = render_corpus_with("torus-v06/scene.xml", &opts);
    // A sun above the floor (the scene is Z-up) and a sky.
    let sun = s
        .scene
        .emitters
        .iter()
        .find_map(|e| match e {
            focal_render::emitter::Emitter::Directional { direction, .. } => Some(*direction),
            _ => None,
        })
        .expect("directional sun");
    assert!(sun.z < -0.5, "sun shines downwards: {sun}");
    assert!(s.scene.environment.is_some());
}

#[test]
fn sms_ring_cylinder_renders_with_path_override() {
    let (s, _) = render_corpus_with(
        "sms-ring/ring.xml",
        &BuildOptions {
            integrator_override: Some("path".into()),
            ..Default::default()
        },
    );
    assert!(s
        .scene
        .geometries
        .iter()
        .any(|g| matches!(g, focal_render::geometry::ShapeGeometry::Cylinder(_))));
}

#[test]
fn sms_plane_normalmap_renders() {
    render_corpus("sms-plane-normalmap/plane_notebook.xml", None);
}

#[test]
fn glass_of_milk_media_are_a_clear_early_error() {
    let e = load_corpus("glass-of-milk/scene.xml", &BuildOptions::default())
        .err()
        .expect("media are not supported");
    assert!(
        e.contains("homogeneous") && e.contains("scene.xml:27:") && e.contains("media"),
        "{e}"
    );
}

#[test]
fn shapegroup_instances_are_flattened_with_their_transforms() {
    let xml = r#"<scene version="3.0.0">
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
            <integer name="height" value="4"/></film></sensor>
        <shape type="shapegroup" id="pair">
            <shape type="sphere"><float name="radius" value="0.5"/></shape>
            <shape type="rectangle"><transform name="to_world"><translate x="2"/></transform></shape>
        </shape>
        <shape type="instance"><ref id="pair"/><transform name="to_world"><translate y="10"/></transform></shape>
        <shape type="instance"><ref id="pair"/><transform name="to_world"><scale value="2"/></transform></shape>
    </scene>"#;
    let s = load_str(xml, std::path::Path::new("."));
    assert_eq!(s.scene.geometries.len(), 4);
    let centres: Vec<glam::Vec3> = s
        .scene
        .geometries
        .iter()
        .map(|g| {
            let b = g.bounds();
            (b.min + b.max) * 0.5
        })
        .collect();
    let near = |a: glam::Vec3, b: glam::Vec3| (a - b).length() < 1e-4;
    assert!(near(centres[0], glam::Vec3::new(0.0, 10.0, 0.0)));
    assert!(near(centres[1], glam::Vec3::new(2.0, 10.0, 0.0)));
    assert!(near(centres[3], glam::Vec3::new(4.0, 0.0, 0.0)));
    let focal_render::geometry::ShapeGeometry::Sphere(sp) = &s.scene.geometries[2] else {
        panic!("sphere")
    };
    assert!((sp.radius - 1.0).abs() < 1e-5);
}
