//! Tests of the Mitsuba XML reader: the real scenes of the vendored corpus, and one small document per rule.

use focal_render::color::srgb_to_linear;
use focal_render::desc::xml::{look_at, parse_scene_file, parse_scene_str, to_snake_case};
use focal_render::desc::{ObjectClass, ObjectDesc, PropValue, SceneDesc, SpectrumDesc};
use focal_render::testing::test_data_dir;
use glam::{DVec3, Mat4, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const FILE: &str = "/virtual/dir/test.xml";

fn parse_with(xml: &str, params: &[(&str, &str)]) -> Result<SceneDesc, String> {
    let params: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    parse_scene_str(xml, Path::new(FILE), &params).map_err(|e| e.to_string())
}

fn parse(xml: &str) -> SceneDesc {
    parse_with(xml, &[]).unwrap_or_else(|e| panic!("parse failed: {e}"))
}

fn parse_err(xml: &str) -> String {
    match parse_with(xml, &[]) {
        Ok(_) => panic!("expected an error for\n{xml}"),
        Err(e) => e,
    }
}

/// A 3.0 scene around `body`.
fn scene3(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{body}\n</scene>")
}

fn first_child(s: &SceneDesc) -> &ObjectDesc {
    &s.root.children[0].object
}

/// The `to_world` transform of the first top-level plugin.
fn to_world(transform_body: &str) -> Mat4 {
    let s = parse(&scene3(&format!(
        "<shape type=\"sphere\"><transform name=\"to_world\">{transform_body}</transform></shape>"
    )));
    first_child(&s).transform_or_identity("to_world").unwrap()
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("focal-xml-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

// ----- the corpus ----------------------------------------------------------------------------------

#[test]
fn every_corpus_and_reference_scene_parses() {
    let data = test_data_dir();
    let mut files: Vec<PathBuf> = Vec::new();
    for dir in [data.join("corpus"), data.join("references/scenes")] {
        let mut folders = vec![dir.clone()];
        folders.extend(
            std::fs::read_dir(&dir)
                .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
                .map(|e| e.unwrap().path())
                .filter(|p| p.is_dir()),
        );
        for folder in folders {
            for entry in std::fs::read_dir(&folder).unwrap() {
                let p = entry.unwrap().path();
                if p.extension().is_some_and(|e| e == "xml") {
                    files.push(p);
                }
            }
        }
    }
    for named in [
        "corpus/cbox-mi3/cbox.xml",
        "corpus/cbox-mi05/cbox.xml",
        "corpus/veach-mis-mi3/integrator_direct_both.xml",
        "corpus/torus-v06/scene.xml",
        "corpus/veach-bidir/scene.xml",
        "corpus/glass-of-milk/scene.xml",
        "corpus/sms-ring/ring.xml",
        "corpus/sms-plane-normalmap/plane_notebook.xml",
        "references/scenes/cbox.xml",
        "references/scenes/caustic.xml",
        "references/scenes/obscura.xml",
    ] {
        assert!(
            files.contains(&data.join(named)),
            "{named} missing from tests/data"
        );
    }
    for f in &files {
        let s = parse_scene_file(f, &[]).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            !s.root.children.is_empty(),
            "{} has no plugins",
            f.display()
        );
    }
}

#[test]
fn legacy_cornell_box_reads_like_a_3x_scene() {
    let s = parse_scene_file(&test_data_dir().join("corpus/cbox-mi05/cbox.xml"), &[]).unwrap();
    assert_eq!(s.version, (0, 5, 0));
    let integrator = &s
        .root
        .children_of(&ObjectClass::Integrator)
        .next()
        .unwrap()
        .object;
    assert_eq!(integrator.int_or("max_depth", -1).unwrap(), 10);
    assert_eq!(integrator.int_or("rr_depth", -1).unwrap(), 10);
    let sensor = &s
        .root
        .children_of(&ObjectClass::Sensor)
        .next()
        .unwrap()
        .object;
    assert_eq!(sensor.string_or("fov_axis", "x").unwrap(), "smaller");
    assert_eq!(sensor.float_or("near_clip", 0.0).unwrap(), 10.0);
    // <lookAt> (0.5 spelling) looking along +Z from (278, 273, -800).
    let m = sensor.transform_or_identity("to_world").unwrap();
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(278.0, 273.0, -800.0)
    ));
    assert!(close(m.transform_vector3(Vec3::Z), Vec3::Z));
    let sampler = &sensor
        .children_of(&ObjectClass::Sampler)
        .next()
        .unwrap()
        .object;
    assert_eq!(sampler.int_or("sample_count", 0).unwrap(), 128);

    // The floor and the ceiling share the one "white" BSDF.
    let shapes: Vec<_> = s.root.children_of(&ObjectClass::Shape).collect();
    let bsdf = |i: usize| {
        shapes[i]
            .object
            .children_of(&ObjectClass::Bsdf)
            .next()
            .unwrap()
            .object
            .clone()
    };
    assert!(Arc::ptr_eq(&bsdf(1), &bsdf(2)));
    assert_eq!(bsdf(1).id.as_deref(), Some("white"));
    match &bsdf(1).prop("reflectance").unwrap().value {
        PropValue::Spectrum(SpectrumDesc::Sampled(p)) => assert_eq!(p[0], (400.0, 0.343)),
        v => panic!("unexpected {v:?}"),
    }
}

#[test]
fn included_scene_is_inlined_and_its_files_resolve_like_mitsuba() {
    let main = test_data_dir().join("corpus/veach-mis-mi3/integrator_direct_both.xml");
    let s = parse_scene_file(&main, &[]).unwrap();
    assert_eq!(s.root.children_of(&ObjectClass::Integrator).count(), 1);
    assert_eq!(s.root.children_of(&ObjectClass::Shape).count(), 10);
    let sensor = &s
        .root
        .children_of(&ObjectClass::Sensor)
        .next()
        .unwrap()
        .object;
    assert!(sensor.loc.file.ends_with("include/veach_mis.xml"));
    let sampler = &sensor
        .children_of(&ObjectClass::Sampler)
        .next()
        .unwrap()
        .object;
    assert_eq!(sampler.int_or("sample_count", 0).unwrap(), 64);
    // "meshes/veach/plate1.obj" lives beside the main file, not beside the included one.
    let plate = s
        .root
        .children_of(&ObjectClass::Shape)
        .find(|c| c.object.plugin == "obj")
        .unwrap();
    let (path, _) = plate.object.resolve_path("filename").unwrap().unwrap();
    assert!(path.is_file(), "{}", path.display());

    // -D overrides the included default.
    let s = parse_scene_file(&main, &[("spp".into(), "3".into())]).unwrap();
    let sensor = &s
        .root
        .children_of(&ObjectClass::Sensor)
        .next()
        .unwrap()
        .object;
    let sampler = &sensor
        .children_of(&ObjectClass::Sampler)
        .next()
        .unwrap()
        .object;
    assert_eq!(sampler.int_or("sample_count", 0).unwrap(), 3);
}

#[test]
fn named_refs_keep_their_name() {
    let s = parse_scene_file(&test_data_dir().join("corpus/glass-of-milk/scene.xml"), &[]).unwrap();
    let milk_top = s.root.children_of(&ObjectClass::Shape).nth(1).unwrap();
    let interior = milk_top.object.named_child("interior").unwrap();
    assert_eq!(interior.object.class, ObjectClass::Medium);
    assert_eq!(interior.object.id.as_deref(), Some("milk"));
}

// ----- transforms ----------------------------------------------------------------------------------

#[test]
fn transform_children_apply_in_document_order() {
    let m = to_world(r#"<translate x="1"/><scale value="2"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(2.0, 0.0, 0.0)
    ));
    assert!(close(m.transform_point3(Vec3::X), Vec3::new(4.0, 0.0, 0.0)));
    let m = to_world(r#"<scale value="2"/><translate x="1"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(1.0, 0.0, 0.0)
    ));
}

#[test]
fn rotate_is_right_handed_in_degrees() {
    let m = to_world(r#"<rotate x="1" angle="90"/>"#);
    assert!(close(m.transform_vector3(Vec3::Z), Vec3::NEG_Y));
    assert!(close(m.transform_vector3(Vec3::Y), Vec3::Z));
    let m = to_world(r#"<rotate value="0, 0, 2" angle="90"/>"#);
    assert!(close(m.transform_vector3(Vec3::X), Vec3::Y));
    assert!(parse_err(&scene3(
        r#"<shape type="sphere"><transform name="to_world"><rotate angle="90"/></transform></shape>"#
    ))
    .contains("non-zero axis"));
}

#[test]
fn translate_and_scale_forms() {
    let m = to_world(r#"<translate value="1 2 3"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(1.0, 2.0, 3.0)
    ));
    let m = to_world(r#"<translate y="2"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(0.0, 2.0, 0.0)
    ));
    // Missing scale components are 1.
    let m = to_world(r#"<scale x=".5" y="3"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ONE),
        Vec3::new(0.5, 3.0, 1.0)
    ));
    let m = to_world(r#"<scale value="2, 3, 4"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ONE),
        Vec3::new(2.0, 3.0, 4.0)
    ));
}

#[test]
fn matrix_is_row_major() {
    let m = to_world(r#"<matrix value="0 -1 0 5  1 0 0 6  0 0 1 7  0 0 0 1"/>"#);
    assert!(close(
        m.transform_point3(Vec3::ZERO),
        Vec3::new(5.0, 6.0, 7.0)
    ));
    assert!(close(m.transform_vector3(Vec3::X), Vec3::Y));
    let m = to_world(r#"<matrix value="0 -1 0  1 0 0  0 0 1"/>"#);
    assert!(close(m.transform_vector3(Vec3::X), Vec3::Y));
    assert!(close(m.transform_point3(Vec3::ZERO), Vec3::ZERO));
    assert!(parse_err(&scene3(
        r#"<shape type="sphere"><transform name="to_world"><matrix value="1 2 3"/></transform></shape>"#
    ))
    .contains("16"));
}

#[test]
fn lookat_builds_mitsubas_camera_frame() {
    let m = to_world(r#"<lookat origin="1, 2, 3" target="1, 2, 2" up="0, 1, 0"/>"#);
    // dir = -Z, left = up × dir = -X, up' = dir × left = +Y, origin in the last column.
    assert!(close(m.x_axis.truncate(), Vec3::NEG_X));
    assert!(close(m.y_axis.truncate(), Vec3::Y));
    assert!(close(m.z_axis.truncate(), Vec3::NEG_Z));
    assert!(close(m.w_axis.truncate(), Vec3::new(1.0, 2.0, 3.0)));

    // A general frame: columns are [left, up', dir, origin] and orthonormal.
    let (o, t, up) = (
        DVec3::new(0.6, 4.6, 6.2),
        DVec3::new(0.5, 0.45, 0.3),
        DVec3::new(0.0, 1.0, 0.0),
    );
    let m = look_at(o, t, up).unwrap();
    let dir = (t - o).normalize();
    let left = up.cross(dir).normalize();
    assert!((m.z_axis.truncate() - dir).length() < 1e-12);
    assert!((m.x_axis.truncate() - left).length() < 1e-12);
    assert!((m.y_axis.truncate() - dir.cross(left)).length() < 1e-12);

    // Up parallel to the view direction, or missing: any perpendicular up.
    for up in [r#"up="0, 5, 0""#, ""] {
        let m = to_world(&format!(
            r#"<lookat origin="0, 0, 0" target="0, 3, 0" {up}/>"#
        ));
        let (l, u, d) = (
            m.x_axis.truncate(),
            m.y_axis.truncate(),
            m.z_axis.truncate(),
        );
        assert!(close(d, Vec3::Y));
        assert!(l.is_finite() && u.is_finite());
        assert!((l.length() - 1.0).abs() < 1e-5 && (u.length() - 1.0).abs() < 1e-5);
        assert!(l.dot(d).abs() < 1e-5 && u.dot(d).abs() < 1e-5 && l.dot(u).abs() < 1e-5);
        assert!(close(d.cross(l), u));
    }
    assert!(parse_err(&scene3(
        r#"<sensor type="perspective"><transform name="to_world"><lookat origin="1,1,1" target="1,1,1"/></transform></sensor>"#
    ))
    .contains("origin equal to target"));
}

// ----- names and dialects --------------------------------------------------------------------------

#[test]
fn camel_case_names_become_snake_case() {
    for (camel, snake) in [
        ("toWorld", "to_world"),
        ("intIOR", "int_ior"),
        ("extEta", "ext_eta"),
        ("alphaU", "alpha_u"),
        ("extIORScale", "ext_ior_scale"),
        ("sampleCount", "sample_count"),
        ("rrDepth", "rr_depth"),
        ("shapeIndex", "shape_index"),
        ("cutoffAngle", "cutoff_angle"),
        ("bsdf_0", "bsdf_0"),
        ("to_world", "to_world"),
        ("uv2Scale", "uv2_scale"),
    ] {
        assert_eq!(to_snake_case(camel), snake, "{camel}");
    }
}

#[test]
fn version_06_file_with_camera_and_camel_case() {
    let s = parse(
        r#"<scene version="0.6.0">
    <camera type="perspective">
        <float name="nearClip" value="0.1"/>
        <transform name="toWorld"><lookAt origin="0 0 0" target="0 0 1" up="0 1 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/></film>
    </camera>
    <shape type="sphere">
        <bsdf type="dielectric" name="bsdf"><float name="intIOR" value="1.33"/></bsdf>
        <boolean name="flipNormals" value="TRUE"/>
    </shape>
    <bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.3"/></bsdf>
    <texture type="bitmap" id="tex">
        <float name="uscale" value="2"/><float name="voffset" value="0.5"/>
    </texture>
</scene>"#,
    );
    assert_eq!(s.version, (0, 6, 0));
    let cam = first_child(&s);
    assert_eq!(cam.class, ObjectClass::Sensor);
    assert_eq!(cam.float_or("near_clip", 0.0).unwrap(), 0.1);
    assert!(cam.prop("to_world").is_some());
    let shape = &s.root.children[1].object;
    assert!(shape.bool_or("flip_normals", false).unwrap());
    let bsdf = shape.named_child("bsdf").unwrap();
    assert_eq!(bsdf.object.float_or("int_ior", 0.0).unwrap(), 1.33);
    // Mitsuba 3's upgrade of pre-2.0 files.
    let diffuse = &s.root.children[2].object;
    assert_eq!(
        diffuse.rgb_or("reflectance", Vec3::ZERO).unwrap(),
        Vec3::splat(0.3)
    );
    let tex = &s.root.children[3].object;
    assert!(tex.prop("uscale").is_none());
    let uv = tex.transform_or_identity("to_uv").unwrap();
    // Translate by (0, 0.5), then scale u by 2.
    assert!(close(
        uv.transform_point3(Vec3::new(1.0, 1.0, 0.0)),
        Vec3::new(2.0, 1.5, 0.0)
    ));
}

#[test]
fn source_locations_are_file_line_column() {
    let s = parse("<scene version=\"3.0.0\">\n  <shape type=\"cube\">\n    <float name=\"x\" value=\"1\"/>\n  </shape>\n</scene>");
    let shape = first_child(&s);
    assert_eq!((shape.loc.line, shape.loc.col), (2, 3));
    assert_eq!(shape.loc.file.as_path(), Path::new(FILE));
    let p = shape.prop("x").unwrap();
    assert_eq!((p.loc.line, p.loc.col), (3, 5));
}

// ----- property values -----------------------------------------------------------------------------

#[test]
fn property_values() {
    let s = parse(&scene3(
        r##"<bsdf type="x">
    <rgb name="grey" value="0.25"/>
    <rgb name="c" value="0.1,0.2 , 0.3"/>
    <srgb name="s" value="0.5, 1, 0"/>
    <srgb name="hex" value="#ff0000"/>
    <spectrum name="u" value="0.7"/>
    <spectrum name="samp" value="400:0.1, 500:0.2 600:0.3"/>
    <spectrum name="wv" wavelengths="400, 700" values="1, 2"/>
    <blackbody name="bb" temperature="6500K"/>
    <point name="p" x="1" z="3"/>
    <vector name="v" value="1, 2, 3"/>
    <integer name="i" value="-4"/>
    <boolean name="b" value="False"/>
    <string name="str" value="hello world"/>
    <float name="f" value="1e-3"/>
</bsdf>"##,
    ));
    let b = first_child(&s);
    let v = |n: &str| b.prop(n).unwrap().value.clone();
    assert_eq!(v("grey"), PropValue::Rgb(Vec3::splat(0.25)));
    assert_eq!(v("c"), PropValue::Rgb(Vec3::new(0.1, 0.2, 0.3)));
    assert_eq!(
        v("s"),
        PropValue::Rgb(Vec3::new(srgb_to_linear(0.5), 1.0, 0.0))
    );
    assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
    assert_eq!(v("hex"), PropValue::Rgb(Vec3::new(1.0, 0.0, 0.0)));
    assert_eq!(v("u"), PropValue::Spectrum(SpectrumDesc::Uniform(0.7)));
    assert_eq!(
        v("samp"),
        PropValue::Spectrum(SpectrumDesc::Sampled(vec![
            (400.0, 0.1),
            (500.0, 0.2),
            (600.0, 0.3)
        ]))
    );
    assert_eq!(
        v("wv"),
        PropValue::Spectrum(SpectrumDesc::Sampled(vec![(400.0, 1.0), (700.0, 2.0)]))
    );
    assert_eq!(
        v("bb"),
        PropValue::Spectrum(SpectrumDesc::Blackbody(6500.0))
    );
    assert_eq!(v("p"), PropValue::Point(Vec3::new(1.0, 0.0, 3.0)));
    assert_eq!(v("v"), PropValue::Vector(Vec3::new(1.0, 2.0, 3.0)));
    assert_eq!(v("i"), PropValue::Integer(-4));
    assert_eq!(v("b"), PropValue::Boolean(false));
    assert_eq!(v("str"), PropValue::String("hello world".into()));
    assert_eq!(v("f"), PropValue::Float(1e-3));
}

#[test]
fn bad_values_are_located_errors() {
    let e = parse_err("<scene version=\"3.0.0\">\n<bsdf type=\"d\">\n<float name=\"a\" value=\"1.2.3\"/>\n</bsdf></scene>");
    assert!(
        e.starts_with(&format!("{FILE}:3:1:")) && e.contains("1.2.3"),
        "{e}"
    );
    for (body, needle) in [
        (r#"<float name="a" value="nan"/>"#, "nan"),
        (r#"<integer name="a" value="1.5"/>"#, "1.5"),
        (r#"<boolean name="a" value="yes"/>"#, "yes"),
        (r#"<rgb name="a" value="1 2"/>"#, "one or three"),
        (r#"<spectrum name="a" filename="x.spd"/>"#, "x.spd"),
        (r#"<spectrum name="a" value="500:1, 400:2"/>"#, "increasing"),
        (r#"<spectrum name="a" value="1 2 3"/>"#, "pairs"),
        (r#"<point name="a" x="1" value="2"/>"#, "mix"),
        (r#"<float name="a" value="1" extra="2"/>"#, "extra"),
        (r#"<float value="1"/>"#, "name"),
        (
            r#"<float name="a" value="1"/><float name="a" value="2"/>"#,
            "more than once",
        ),
        (r#"<null/>"#, "<null>"),
        (r#"<frobnicate/>"#, "<frobnicate>"),
        (r#"<translate x="1"/>"#, "<transform>"),
        (r#"<shape/>"#, "type"),
        (r#"some text"#, "unexpected text"),
    ] {
        let e = parse_err(&scene3(&format!("<bsdf type=\"d\">{body}</bsdf>")));
        assert!(
            e.contains(needle) && e.contains("test.xml:2:"),
            "{body}: {e}"
        );
    }
}

#[test]
fn unknown_plugin_tags_are_kept_as_other() {
    let s = parse(&scene3(r#"<volume type="gridvolume" name="density"/>"#));
    assert_eq!(first_child(&s).class, ObjectClass::Other("volume".into()));
    assert_eq!(s.root.children[0].name.as_deref(), Some("density"));
}

// ----- variables -----------------------------------------------------------------------------------

const VARS: &str = r#"<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="name" value="bunny"/>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <shape type="obj"><string name="filename" value="meshes/$name.obj"/></shape>
</scene>"#;

#[test]
fn variables_take_defaults_and_overrides() {
    let s = parse_with(VARS, &[]).unwrap();
    assert_eq!(first_child(&s).int_or("sample_count", 0).unwrap(), 16);
    assert_eq!(
        s.root.children[1].object.string_or("filename", "").unwrap(),
        "meshes/bunny.obj"
    );
    let s = parse_with(VARS, &[("spp", "4"), ("name", "dragon")]).unwrap();
    assert_eq!(first_child(&s).int_or("sample_count", 0).unwrap(), 4);
    assert_eq!(
        s.root.children[1].object.string_or("filename", "").unwrap(),
        "meshes/dragon.obj"
    );
    // Variables work in any attribute, type included.
    let s = parse_with(
        &scene3(r#"<integrator type="$kind"/>"#),
        &[("kind", "path")],
    )
    .unwrap();
    assert_eq!(first_child(&s).plugin, "path");
}

#[test]
fn unused_and_missing_variables_are_errors() {
    let e = parse_with(VARS, &[("spp", "4"), ("sppp", "5")]).unwrap_err();
    assert!(e.contains("unused") && e.contains("sppp"), "{e}");
    // Old files did not check.
    let old = VARS.replace("3.0.0", "0.6.0");
    assert!(parse_with(&old, &[("whatever", "1")]).is_ok());

    let e = parse_err("<scene version=\"3.0.0\">\n\n<sampler type=\"independent\"><integer name=\"sample_count\" value=\"$spp\"/></sampler></scene>");
    assert!(e.contains("'$spp'") && e.contains("test.xml:3:"), "{e}");
}

// ----- ids, refs, aliases --------------------------------------------------------------------------

#[test]
fn refs_share_objects_declared_anywhere_before() {
    let s = parse(&scene3(
        r#"<shape type="sphere"><bsdf type="diffuse" id="inner"/></shape>
           <shape type="sphere"><ref id="inner"/><ref name="interior" id="inner"/></shape>
           <alias id="inner" as="other"/>
           <shape type="sphere"><ref id="other"/></shape>"#,
    ));
    let a = &s.root.children[0].object.children[0].object;
    let b = &s.root.children[1].object.children;
    assert!(Arc::ptr_eq(a, &b[0].object) && Arc::ptr_eq(a, &b[1].object));
    assert_eq!(b[1].name.as_deref(), Some("interior"));
    assert!(Arc::ptr_eq(
        a,
        &s.root.children[2].object.children[0].object
    ));

    assert!(
        parse_err(&scene3(r#"<shape type="sphere"><ref id="nope"/></shape>"#)).contains("'nope'")
    );
    assert!(
        parse_err(&scene3(r#"<bsdf type="d" id="a"/><bsdf type="d" id="a"/>"#))
            .contains("duplicate id")
    );
    assert!(parse_err(&scene3(r#"<alias id="nope" as="b"/>"#)).contains("'nope'"));
}

// ----- files ---------------------------------------------------------------------------------------

#[test]
fn includes_inline_and_fail_cleanly() {
    let dir = temp_dir("include");
    std::fs::create_dir_all(dir.join("parts")).unwrap();
    std::fs::write(
        dir.join("parts/materials.xml"),
        r#"<scene version="3.0.0"><default name="r" value="0.5"/><bsdf type="diffuse" id="white"><rgb name="reflectance" value="$r"/></bsdf></scene>"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("parts/single.xml"),
        r#"<emitter type="constant"/>"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("main.xml"),
        "<scene version=\"3.0.0\">\n<include filename=\"parts/materials.xml\"/>\n<shape type=\"sphere\"><ref id=\"white\"/></shape>\n<include filename=\"parts/single.xml\"/>\n</scene>",
    )
    .unwrap();
    let s = parse_scene_file(&dir.join("main.xml"), &[]).unwrap();
    assert_eq!(s.root.children.len(), 3);
    assert_eq!(
        s.root.children[0]
            .object
            .rgb_or("reflectance", Vec3::ZERO)
            .unwrap(),
        Vec3::splat(0.5)
    );
    assert!(s.root.children[0]
        .object
        .loc
        .file
        .ends_with("parts/materials.xml"));
    assert_eq!(s.root.children[2].object.class, ObjectClass::Emitter);

    std::fs::write(
        dir.join("missing.xml"),
        "<scene version=\"3.0.0\">\n\n<include filename=\"nope.xml\"/></scene>",
    )
    .unwrap();
    let e = parse_scene_file(&dir.join("missing.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing.xml:3:") && e.contains("nope.xml"),
        "{e}"
    );

    std::fs::write(
        dir.join("cycle.xml"),
        "<scene version=\"3.0.0\"><include filename=\"cycle.xml\"/></scene>",
    )
    .unwrap();
    let e = parse_scene_file(&dir.join("cycle.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("cycle"), "{e}");

    std::fs::write(
        dir.join("broken_inc.xml"),
        "<scene version=\"3.0.0\"><include filename=\"bad.xml\"/></scene>",
    )
    .unwrap();
    std::fs::write(
        dir.join("bad.xml"),
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n</scene>",
    )
    .unwrap();
    let e = parse_scene_file(&dir.join("broken_inc.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.xml:3:"), "{e}");
}

#[test]
fn malformed_xml_and_missing_files() {
    let e = parse_err("<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>");
    assert!(
        e.starts_with(&format!("{FILE}:3:")) && e.contains("malformed XML"),
        "{e}"
    );
    let e = parse_err("<scene>\n</scene>");
    assert!(e.contains("version"), "{e}");
    let e = parse_err("<shape type=\"sphere\"/>");
    assert!(e.contains("root element"), "{e}");
    let e = parse_scene_file(Path::new("/nonexistent/nowhere.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("nowhere.xml"), "{e}");
}

#[test]
fn search_paths_resolve_filenames() {
    let dir = temp_dir("search_path");
    std::fs::create_dir_all(dir.join("assets")).unwrap();
    std::fs::write(dir.join("assets/mesh.obj"), "v 0 0 0\n").unwrap();
    std::fs::write(
        dir.join("main.xml"),
        r#"<scene version="3.0.0"><path value="assets"/>
           <shape type="obj"><string name="filename" value="mesh.obj"/></shape>
           <shape type="obj"><string name="filename" value="absent.obj"/></shape></scene>"#,
    )
    .unwrap();
    let s = parse_scene_file(&dir.join("main.xml"), &[]).unwrap();
    let (found, _) = s.root.children[0]
        .object
        .resolve_path("filename")
        .unwrap()
        .unwrap();
    assert!(
        found.is_file() && found.ends_with("assets/mesh.obj"),
        "{}",
        found.display()
    );
    // Files found nowhere stay relative to the XML file (the loader will report them).
    let (absent, _) = s.root.children[1]
        .object
        .resolve_path("filename")
        .unwrap()
        .unwrap();
    assert_eq!(absent, dir.join("absent.obj"));
}

/// Every Mitsuba 0.6 BSDF parameter name we map reaches the Mitsuba 3 parameter: one shape per BSDF, in
/// order, each with the 0.6 spelling of its parameters.
#[test]
fn version_06_bsdf_parameters_map_to_mitsuba3() {
    use focal_render::bsdf::{Bsdf, MicrofacetKind};
    use focal_render::scene::{build_scene, BuildOptions};
    let bsdfs = [
        r#"<bsdf type="diffuse"><spectrum name="diffuseReflectance" value="0.3"/></bsdf>"#,
        r#"<bsdf type="dielectric"><float name="intIOR" value="1.6"/><float name="extIOR" value="1.2"/>
            <spectrum name="specularReflectance" value="0.7"/><spectrum name="specularTransmittance" value="0.6"/></bsdf>"#,
        r#"<bsdf type="thindielectric"><string name="intIOR" value="water"/><string name="extIOR" value="vacuum"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/>
            <float name="alphaU" value="0.2"/><float name="alphaV" value="0.3"/><boolean name="sampleVisible" value="false"/></bsdf>"#,
        r#"<bsdf type="conductor"><spectrum name="eta" value="0.5"/><spectrum name="k" value="2"/>
            <float name="extEta" value="1.25"/><spectrum name="specularReflectance" value="0.8"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.15"/></bsdf>"#,
        r#"<bsdf type="plastic"><spectrum name="diffuseReflectance" value="0.2"/>
            <spectrum name="specularReflectance" value="0.9"/><float name="intIOR" value="1.5"/><float name="extIOR" value="1"/>
            <boolean name="nonlinear" value="true"/></bsdf>"#,
        r#"<bsdf type="roughplastic"><float name="alpha" value="0.25"/><boolean name="nonlinear" value="true"/>
            <spectrum name="diffuseReflectance" value="0.4"/></bsdf>"#,
        r#"<bsdf type="difftrans"><spectrum name="transmittance" value="0.35"/></bsdf>"#,
        r#"<bsdf type="mask"><spectrum name="opacity" value="0.75"/><bsdf type="diffuse"/></bsdf>"#,
        r#"<bsdf type="conductor"/>"#,
        r#"<bsdf type="difftrans"><spectrum name="diffuseTransmittance" value="0.45"/></bsdf>"#,
    ];
    let shapes: String = bsdfs
        .iter()
        .map(|b| format!("<shape type=\"sphere\">{b}</shape>\n"))
        .collect();
    let xml = format!(
        r#"<scene version="0.6.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    {shapes}</scene>"#
    );
    let desc = parse_scene_str(&xml, Path::new(FILE), &[]).unwrap_or_else(|e| panic!("{e}"));
    let loaded = build_scene(&desc, &BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let b = &loaded.scene.bsdfs;
    assert_eq!(b.len(), bsdfs.len());
    let uv = glam::Vec2::ZERO;
    let grey = |t: &focal_render::texture::Texture| t.eval(uv).x;
    let near = |a: f32, b: f32| (a - b).abs() < 1e-6;

    let Bsdf::Diffuse(d) = &b[0] else {
        panic!("{:?}", b[0])
    };
    assert!(near(grey(&d.reflectance), 0.3));
    let Bsdf::Dielectric(d) = &b[1] else {
        panic!("{:?}", b[1])
    };
    assert!(near(d.eta, 1.6 / 1.2));
    assert!(near(grey(&d.specular_reflectance), 0.7) && near(grey(&d.specular_transmittance), 0.6));
    let Bsdf::ThinDielectric(d) = &b[2] else {
        panic!("{:?}", b[2])
    };
    assert!(near(d.eta, 1.333));
    let Bsdf::RoughDielectric(d) = &b[3] else {
        panic!("{:?}", b[3])
    };
    assert_eq!(d.distribution.kind, MicrofacetKind::Ggx);
    assert_eq!((d.distribution.alpha_u, d.distribution.alpha_v), (0.2, 0.3));
    assert!(!d.distribution.sample_visible);
    let Bsdf::Conductor(c) = &b[4] else {
        panic!("{:?}", b[4])
    };
    assert!(near(grey(&c.eta), 0.4) && near(grey(&c.k), 1.6));
    assert!(near(grey(&c.specular_reflectance), 0.8));
    let Bsdf::RoughConductor(c) = &b[5] else {
        panic!("{:?}", b[5])
    };
    assert!(near(c.eta.eval(uv).x, 0.143036) && near(c.k.eval(uv).z, 1.603359));
    assert_eq!(c.distribution.alpha_u, 0.15);
    let Bsdf::Plastic(p) = &b[6] else {
        panic!("{:?}", b[6])
    };
    assert!(near(p.eta, 1.5) && p.nonlinear);
    assert!(near(grey(&p.diffuse_reflectance), 0.2));
    assert!(near(grey(p.specular_reflectance.as_ref().unwrap()), 0.9));
    let Bsdf::RoughPlastic(p) = &b[7] else {
        panic!("{:?}", b[7])
    };
    assert!(p.nonlinear && p.distribution.alpha_u == 0.25);
    assert!(near(grey(&p.diffuse_reflectance), 0.4));
    let Bsdf::DiffuseTransmitter(t) = &b[8] else {
        panic!("{:?}", b[8])
    };
    assert!(near(grey(&t.transmittance), 0.35));
    let ctx = focal_render::bsdf::BsdfContext::default();
    assert_eq!(b[9].pass_through(&ctx), Some(Vec3::splat(0.25)));
    // A 0.6 conductor without a material: Mitsuba 3's mirror, with a warning naming 0.6's copper.
    let Bsdf::Conductor(c) = &b[10] else {
        panic!("{:?}", b[10])
    };
    assert!(near(grey(&c.eta), 0.0) && near(grey(&c.k), 1.0));
    let Bsdf::DiffuseTransmitter(t) = &b[11] else {
        panic!("{:?}", b[11])
    };
    assert!(near(grey(&t.transmittance), 0.45));
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].contains("Cu"), "{:?}", loaded.warnings);
}
