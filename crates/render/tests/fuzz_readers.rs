//! Fuzzing of the scene readers by byte mutation (proptest): mutated scene XML (parsed and built, with
//! OBJ, PLY and serialized meshes it references) and mutated OBJ, PLY and serialized mesh files must
//! never panic, and every failure must be an error that says where (file, and line where there is one).
//!
//! The default run is short (a few hundred cases in all). The long, benchmark-style run is
//! `tools/fuzz-readers.sh` (sets `FOCAL_FUZZ_CASES`, release mode; its run time:
//! `docs/experiments/2026-12-01-reader-fuzzing.md`).

use focal_render::desc::xml::parse_scene_str;
use focal_render::error::SourceLoc;
use focal_render::mesh::serialized::{parse_serialized, write_serialized};
use focal_render::mesh::{load_obj, load_ply, load_serialized, MeshData};
use focal_render::scene::{build_scene, BuildOptions, Strictness};
use focal_render::texture::{Bitmap, BitmapFilter, UvFootprint, UvTransform, WrapMode};
use glam::{Vec2, Vec3};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

const OBJ: &str = "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
vn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";

const PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
property float z\nproperty float u\nproperty float v\nelement face 2\nproperty list uchar int vertex_indices\n\
end_header\n0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n3 0 1 2\n3 0 2 3\n";

const XML: &str = r#"<scene version="0.6.0">
  <default name="spp" value="4"/>
  <integrator type="guided_path"><integer name="maxDepth" value="5"/></integrator>
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="toWorld"><lookAt origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="$spp"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
      <rfilter type="box"/></film></sensor>
  <bsdf type="twosided" id="gold"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></bsdf>
  <bsdf type="roughplastic" id="plastic"><float name="alpha" value="0.2"/><boolean name="nonlinear" value="true"/></bsdf>
  <shape type="obj"><string name="filename" value="quad.obj"/><ref id="gold"/>
    <transform name="toWorld"><scale x="2" y="2"/><rotate x="1" angle="-90"/></transform></shape>
  <shape type="ply"><string name="filename" value="quad.ply"/><ref id="plastic"/></shape>
  <shape type="serialized"><string name="filename" value="mesh.serialized"/><integer name="shapeIndex" value="1"/>
    <boolean name="faceNormals" value="true"/>
    <bsdf type="mask"><spectrum name="opacity" value="0.5"/><bsdf type="difftrans"/></bsdf></shape>
  <shape type="cylinder"><float name="radius" value="0.3"/><boolean name="flipNormals" value="true"/>
    <bsdf type="dielectric"><string name="intIOR" value="bk7"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="2" z="0"/><float name="radius" value="0.2"/>
    <emitter type="area"><rgb name="radiance" value="10, 9, 8"/></emitter></shape>
  <emitter type="spot"><transform name="toWorld"><lookAt origin="0,3,0" target="0,0,0" up="0,0,1"/></transform></emitter>
</scene>
"#;

/// Mitsuba 0.6 syntax of the paths added for real 0.6 scenes (issue 41): MIP-mapped bitmaps and their
/// parameters, Mitsuba 0.6's leniencies, and the plugins added with the plugin table (also
/// `mixturebsdf`, `coating`, `roughcoating` and a `bumpmap` with a 0.6 `scale` texture).
const XML06: &str = r#"<scene version="0.6.0">
  <integrator type="path_sms_ss"><integer name="maxDepth" value="4"/></integrator>
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="toWorld"><lookAt origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="stratified"><integer name="sampleCount" value="4"/></sampler>
    <film type="tiledhdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
      <string name="pixelFormat" value="rgba"/><rfilter type="gaussian"/></film></sensor>
  <texture type="bitmap" id="tex"><string name="filename" value="image.png"/>
    <string name="filterType" value="trilinear"/><float name="maxAnisotropy" value="4"/>
    <string name="wrapModeU" value="mirror"/><string name="wrapModeV" value="zero"/>
    <float name="gamma" value="2.2"/><string name="channel" value="g"/><boolean name="cache" value="false"/>
    <float name="uscale" value="3"/><float name="voffset" value="0.25"/></texture>
  <shape type="rectangle"><bsdf type="phong"><float name="exponent" value="20"/>
    <ref name="diffuseReflectance" id="tex"/></bsdf></shape>
  <shape type="sphere"><bsdf type="roughconductor"><rgb name="eta" value="-0.05, 4.1, 4.7"/>
    <rgb name="k" value="-1, 2, 3"/><float name="alphaU" value="0.2"/>
    <string name="distribution" value="as"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="2" y="0" z="0"/><bsdf type="conductor">
    <string name="material" value="None"/></bsdf></shape>
  <shape type="disk"><bsdf type="ward"><string name="variant" value="ward-duer"/>
    <float name="alphaU" value="0.1"/><float name="alphaV" value="0.3"/></bsdf></shape>
  <shape type="cube"><bsdf type="roughdiffuse"><texture type="bitmap" name="reflectance">
    <string name="filename" value="image.png"/><string name="wrapMode" value="one"/></texture></bsdf></shape>
  <shape type="cylinder"><bsdf type="null"/></shape>
  <shape type="sphere"><point name="center" x="-2" y="0" z="0"/><bsdf type="mixturebsdf">
    <string name="weights" value="0.3, 0.9"/><bsdf type="diffuse"/><bsdf type="coating">
    <float name="intIOR" value="1.7"/><rgb name="sigmaA" value="0.1, 0.2, 0.3"/>
    <float name="thickness" value="2"/><bsdf type="plastic"/></bsdf></bsdf></shape>
  <shape type="rectangle"><bsdf type="bumpmap"><texture type="scale"><float name="scale" value="0.5"/>
    <texture type="bitmap"><string name="filename" value="image.png"/></texture></texture>
    <bsdf type="roughcoating"><float name="alpha" value="0.3"/><bsdf type="diffuse"/></bsdf></bsdf></shape>
  <emitter type="constant"><spectrum name="radiance" value="1"/></emitter>
</scene>
"#;

fn serialized_seed() -> Vec<u8> {
    let quad = MeshData {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
        normals: Some(vec![Vec3::Z; 4]),
        uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
        indices: vec![[0, 1, 2], [0, 2, 3]],
    };
    let tri = MeshData {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z],
        normals: None,
        uvs: None,
        indices: vec![[0, 1, 2]],
    };
    write_serialized(&[(&quad, "quad"), (&tri, "tri")], 4)
}

/// A directory (one per test process) holding the unmutated mesh files the seed XML references.
fn seed_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("focal-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("quad.obj"), OBJ).unwrap();
        std::fs::write(dir.join("quad.ply"), PLY).unwrap();
        std::fs::write(dir.join("mesh.serialized"), serialized_seed()).unwrap();
        std::fs::copy(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/grazing_texture/checker.png"),
            dir.join("image.png"),
        )
        .unwrap();
        dir
    })
}

fn cases() -> u32 {
    std::env::var("FOCAL_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(48)
}

/// One edit of a byte string: replace, insert or delete at a position (taken modulo the length).
#[derive(Clone, Debug)]
enum Edit {
    Replace(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    /// Copy a run of bytes elsewhere (duplicates tags, numbers, headers).
    Splice(usize, usize, usize),
    Truncate(usize),
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    let byte = prop_oneof![
        any::<u8>(),
        // Bytes that matter to the formats: digits, signs, separators, XML syntax.
        prop::sample::select(b"0123456789-+.eE ,<>/\"=\n\0\xff".to_vec()),
    ];
    let edit = prop_oneof![
        4 => (any::<usize>(), byte.clone()).prop_map(|(i, b)| Edit::Replace(i, b)),
        2 => (any::<usize>(), byte).prop_map(|(i, b)| Edit::Insert(i, b)),
        2 => any::<usize>().prop_map(Edit::Delete),
        1 => (any::<usize>(), any::<usize>(), 1usize..64).prop_map(|(a, b, n)| Edit::Splice(a, b, n)),
        1 => any::<usize>().prop_map(Edit::Truncate),
    ];
    prop::collection::vec(edit, 1..12)
}

fn mutate(seed: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for e in edits {
        let n = b.len().max(1);
        match *e {
            Edit::Replace(i, v) if !b.is_empty() => b[i % n] = v,
            Edit::Insert(i, v) => b.insert(i % (b.len() + 1), v),
            Edit::Delete(i) if !b.is_empty() => {
                b.remove(i % n);
            }
            Edit::Splice(from, to, len) if !b.is_empty() => {
                let from = from % n;
                let run: Vec<u8> = b[from..(from + len).min(b.len())].to_vec();
                let to = to % (b.len() + 1);
                b.splice(to..to, run);
            }
            Edit::Truncate(i) => b.truncate(i % (b.len() + 1)),
            _ => {}
        }
    }
    b
}

fn loc(file: &Path) -> SourceLoc {
    SourceLoc {
        file: Arc::new(file.to_path_buf()),
        line: 3,
        col: 5,
    }
}

/// A mutated mesh file, written next to the seeds under a unique name.
fn write_case(name: &str, bytes: &[u8]) -> PathBuf {
    static COUNTER: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let k = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let path = seed_dir().join(format!("case{k}-{name}"));
    std::fs::write(&path, bytes).unwrap();
    path
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_scene_xml_never_panics(e in edits()) {
        let bytes = mutate(XML.as_bytes(), &e);
        let Ok(text) = std::str::from_utf8(&bytes) else { return Ok(()) };
        let path = seed_dir().join("scene.xml");
        for strictness in [Strictness::Strict, Strictness::Lenient] {
            let r = parse_scene_str(text, &path, &[]).and_then(|d| {
                build_scene(&d, &BuildOptions { strictness, ..Default::default() })
            });
            if let Err(err) = r {
                let msg = err.to_string();
                prop_assert!(err.loc.is_some(), "error without a location: {msg}");
                prop_assert!(!err.message.is_empty());
            }
        }
    }

    #[test]
    fn mutated_mitsuba06_scene_xml_never_panics(e in edits()) {
        let bytes = mutate(XML06.as_bytes(), &e);
        let Ok(text) = std::str::from_utf8(&bytes) else { return Ok(()) };
        let path = seed_dir().join("scene06.xml");
        for strictness in [Strictness::Strict, Strictness::Lenient] {
            let r = parse_scene_str(text, &path, &[]).and_then(|d| {
                build_scene(&d, &BuildOptions { strictness, ..Default::default() })
            });
            if let Err(err) = r {
                let msg = err.to_string();
                prop_assert!(err.loc.is_some(), "error without a location: {msg}");
                prop_assert!(!err.message.is_empty());
            }
        }
    }

    #[test]
    fn mip_map_lookups_stay_finite(
        w in 1u32..9,
        h in 1u32..9,
        values in prop::collection::vec(0.0f32..10.0, 64),
        uv in (any::<f32>(), any::<f32>()),
        d in (any::<f32>(), any::<f32>(), any::<f32>(), any::<f32>()),
        wrap in (0usize..5, 0usize..5),
    ) {
        let modes = [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp, WrapMode::Zero, WrapMode::One];
        let texels = (0..(w * h) as usize).map(|i| Vec3::splat(values[i % 64])).collect();
        let b = Bitmap::new(w, h, texels, BitmapFilter::Trilinear, [modes[wrap.0], modes[wrap.1]],
            UvTransform::IDENTITY).unwrap();
        let fp = UvFootprint { duv_dx: Vec2::new(d.0, d.1), duv_dy: Vec2::new(d.2, d.3) };
        let v = b.eval_filtered(Vec2::new(uv.0, uv.1), &fp);
        prop_assert!(v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 10.0, "{v}");
        // The bump-map gradient of the same image: finite, at most 10 per texel.
        let g = b.eval_1_grad(Vec2::new(uv.0, uv.1));
        prop_assert!(g.is_finite() && g.abs().max_element() <= 10.0 * 8.0 + 1e-3, "{g}");
    }

    #[test]
    fn mutated_obj_never_panics(e in edits()) {
        let path = write_case("m.obj", &mutate(OBJ.as_bytes(), &e));
        if let Err(err) = load_obj(&path, &loc(&path), true) {
            prop_assert!(err.to_string().contains("m.obj"), "{err}");
        }
        std::fs::remove_file(&path).ok();
    }

    #[test]
    fn mutated_ply_never_panics(e in edits()) {
        let path = write_case("m.ply", &mutate(PLY.as_bytes(), &e));
        if let Err(err) = load_ply(&path, &loc(&path)) {
            prop_assert!(err.to_string().contains("m.ply"), "{err}");
        }
        std::fs::remove_file(&path).ok();
    }

    #[test]
    fn mutated_serialized_never_panics(e in edits(), index in 0i64..3) {
        let bytes = mutate(&serialized_seed(), &e);
        let _ = parse_serialized(&bytes, index);
        let path = write_case("m.serialized", &bytes);
        if let Err(err) = load_serialized(&path, &loc(&path), index) {
            prop_assert!(err.to_string().contains("m.serialized"), "{err}");
        }
        std::fs::remove_file(&path).ok();
    }
}

/// The unmutated Mitsuba 0.6 seed loads (leniently: it names plugins focal only approximates), so
/// the fuzzing starts from scenes that reach the new builders.
#[test]
fn mitsuba06_seed_loads_and_reaches_the_adapters() {
    let path = seed_dir().join("scene06.xml");
    let s = parse_scene_str(XML06, &path, &[])
        .and_then(|d| {
            build_scene(
                &d,
                &BuildOptions {
                    strictness: Strictness::Lenient,
                    ..Default::default()
                },
            )
        })
        .unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = s.scene.bsdfs.iter().map(|b| b.plugin_name()).collect();
    for wanted in ["mixturebsdf", "bumpmap"] {
        assert!(names.contains(&wanted), "{names:?}");
    }
}
