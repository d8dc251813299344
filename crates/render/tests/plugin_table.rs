//! docs/plugins.md, the code's plugin table (focal_render::plugins) and the scene builder agree: the
//! document lists exactly the table's plugins with the same status, every supported plugin loads in
//! strict mode without a warning, every approximated one with a warning naming it, and every
//! unsupported one fails with an error naming it.

use focal_render::desc::xml::parse_scene_str;
use focal_render::mesh::serialized::write_serialized;
use focal_render::mesh::MeshData;
use focal_render::plugins::{Support, PLUGINS};
use focal_render::scene::{build_scene, BuildOptions};
use glam::{Vec2, Vec3};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn repo_file(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(rel)
}

/// (class, plugin, status word) of every table row of docs/plugins.md under a `## class` heading.
fn documented() -> BTreeSet<(String, String, String)> {
    let text = std::fs::read_to_string(repo_file("docs/plugins.md")).expect("docs/plugins.md");
    let mut class = None;
    let mut rows = BTreeSet::new();
    for line in text.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            let h = h.trim();
            class = (!h.contains(' ')).then(|| h.to_string());
            continue;
        }
        let (Some(class), Some(row)) = (&class, line.strip_prefix("| `")) else {
            continue;
        };
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let name = cells[0].trim_end_matches('`');
        assert!(
            rows.insert((class.clone(), name.to_string(), cells[1].to_string())),
            "{class} '{name}' is listed twice"
        );
    }
    rows
}

#[test]
fn the_document_lists_exactly_the_code_table() {
    let docs = documented();
    let code: BTreeSet<(String, String, String)> = PLUGINS
        .iter()
        .map(|p| (p.class.into(), p.name.into(), p.support.word().into()))
        .collect();
    let missing: Vec<_> = code.difference(&docs).collect();
    let extra: Vec<_> = docs.difference(&code).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "in the code's table but not (so) in docs/plugins.md: {missing:?}\n\
         in docs/plugins.md but not (so) in the code: {extra:?}"
    );
}

/// A folder with a mesh of each format and an image, for the plugins that need files.
fn files() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("focal-plugin-table-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("quad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let tri = MeshData {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: None,
        uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::Y]),
        indices: vec![[0, 1, 2]],
    };
    std::fs::write(
        dir.join("tri.serialized"),
        write_serialized(&[(&tri, "tri")], 4),
    )
    .unwrap();
    std::fs::copy(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/grazing_texture/checker.png"),
        dir.join("image.png"),
    )
    .unwrap();
    dir
}

/// A small scene that uses plugin `name` of `class`.
fn scene_using(class: &str, name: &str) -> String {
    let mut integrator = "path".to_string();
    let mut sensor = ("perspective".to_string(), String::new());
    let mut film = "hdrfilm".to_string();
    let mut rfilter = "box".to_string();
    let mut sampler = "independent".to_string();
    let mut body = String::new();
    let image = r#"<string name="filename" value="image.png"/>"#;
    match class {
        "shape" => {
            body = match name {
                "obj" => r#"<shape type="obj"><string name="filename" value="quad.obj"/></shape>"#.into(),
                "ply" => r#"<shape type="ply"><string name="filename" value="quad.ply"/></shape>"#.into(),
                "serialized" => {
                    r#"<shape type="serialized"><string name="filename" value="tri.serialized"/></shape>"#
                        .into()
                }
                "instance" | "shapegroup" => r#"<shape type="shapegroup" id="g"><shape type="sphere"/></shape>
                    <shape type="instance"><ref id="g"/></shape>"#
                    .into(),
                _ => format!(r#"<shape type="{name}"/>"#),
            }
        }
        "bsdf" => {
            let inner = match name {
                "blendbsdf" => r#"<bsdf type="diffuse"/><bsdf type="diffuse"/>"#.to_string(),
                "mixturebsdf" => r#"<string name="weights" value="0.4, 0.6"/>
                    <bsdf type="diffuse"/><bsdf type="diffuse"/>"#
                    .to_string(),
                "normalmap" | "bumpmap" => format!(
                    r#"<bsdf type="diffuse"/><texture type="bitmap" name="{}">{image}</texture>"#,
                    if name == "normalmap" { "normalmap" } else { "bumpmap" }
                ),
                "twosided" | "mask" | "coating" | "roughcoating" => {
                    r#"<bsdf type="diffuse"/>"#.to_string()
                }
                _ => String::new(),
            };
            body = format!(r#"<shape type="sphere"><bsdf type="{name}">{inner}</bsdf></shape>"#);
        }
        "emitter" => {
            body = match name {
                "area" => r#"<shape type="sphere"><emitter type="area"/></shape>"#.into(),
                "envmap" => format!(r#"<emitter type="envmap">{image}</emitter>"#),
                _ => format!(r#"<emitter type="{name}"/>"#),
            }
        }
        "sensor" => {
            let params = if name == "thinlens" {
                r#"<float name="aperture_radius" value="0.1"/>"#.to_string()
            } else {
                String::new()
            };
            sensor = (name.into(), params);
        }
        "film" => film = name.into(),
        "rfilter" => rfilter = name.into(),
        "sampler" => sampler = name.into(),
        "integrator" => integrator = name.into(),
        "texture" => {
            let params = if name == "bitmap" { image } else { "" };
            body = format!(
                r#"<shape type="sphere"><bsdf type="diffuse"><texture type="{name}" name="reflectance">{params}</texture></bsdf></shape>"#
            );
        }
        "spectrum" => {
            body = format!(
                r#"<emitter type="constant"><spectrum type="{name}" name="radiance"/></emitter>"#
            )
        }
        _ => body = format!(r#"<{class} type="{name}"/>"#),
    }
    let (sensor, sensor_params) = sensor;
    format!(
        r#"<scene version="3.0.0">
    <integrator type="{integrator}"/>
    <sensor type="{sensor}">{sensor_params}
        <film type="{film}"><integer name="width" value="4"/><integer name="height" value="4"/>
            <rfilter type="{rfilter}"/></film>
        <sampler type="{sampler}"/>
    </sensor>
    <shape type="rectangle"/>
    {body}
</scene>"#
    )
}

#[test]
fn the_builder_does_what_the_table_says() {
    let dir = files();
    let mut failures = Vec::new();
    for p in PLUGINS {
        let xml = scene_using(p.class, p.name);
        let result = parse_scene_str(&xml, &dir.join("scene.xml"), &[])
            .and_then(|d| build_scene(&d, &BuildOptions::default()));
        let what = format!("{} '{}'", p.class, p.name);
        match (p.support, result) {
            (Support::Supported, Ok(s)) if s.warnings.is_empty() => {}
            (Support::Supported, Ok(s)) => {
                failures.push(format!("{what}: supported but warns {:?}", s.warnings))
            }
            (Support::Approximated, Ok(s)) => {
                if !s
                    .warnings
                    .iter()
                    .any(|w| w.contains(&format!("'{}'", p.name)))
                {
                    failures.push(format!(
                        "{what}: approximated without a warning naming it ({:?})",
                        s.warnings
                    ));
                }
            }
            (Support::Unsupported, Err(e)) => {
                if !e.message.contains(p.name) || e.loc.is_none() {
                    failures.push(format!("{what}: the error does not name it: {e}"));
                }
            }
            (Support::Unsupported, Ok(_)) => {
                failures.push(format!("{what}: listed as an error but loads"))
            }
            (_, Err(e)) => failures.push(format!("{what}: listed as loading but fails: {e}")),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_class_of_the_table_is_a_documented_section() {
    let classes: BTreeSet<&str> = PLUGINS.iter().map(|p| p.class).collect();
    let text = std::fs::read_to_string(repo_file("docs/plugins.md")).unwrap();
    for c in classes {
        assert!(text.contains(&format!("\n## {c}\n")), "no section for {c}");
    }
    assert!(Path::new(&repo_file("docs/plugins.md")).exists());
}
