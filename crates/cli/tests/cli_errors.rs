//! User errors give a clear message with the file and line, a non-zero exit code, and never a panic.

use std::path::PathBuf;
use std::process::Command;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("focal-cli-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const HEADER: &str = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
"#;

fn check_error(name: &str, body: &str, expect_line: u32, expect_words: &[&str]) {
    let d = tmpdir(name);
    let scene = d.join("scene.xml");
    std::fs::write(&scene, format!("{HEADER}{body}")).unwrap();
    let (code, stderr) = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        d.join("o.exr").to_str().unwrap(),
        "-q",
    ]);
    assert_ne!(code, 0, "{name}: expected failure, stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{name}: panic: {stderr}");
    assert!(
        stderr.contains(&format!("scene.xml:{expect_line}:")),
        "{name}: no file:line {expect_line} in: {stderr}"
    );
    for w in expect_words {
        assert!(stderr.contains(w), "{name}: '{w}' missing in: {stderr}");
    }
}

#[test]
fn malformed_xml() {
    check_error(
        "malformed",
        "    <shape type=\"sphere\">\n    </shapex>\n</scene>\n",
        6,
        &[],
    );
}

#[test]
fn missing_mesh_file() {
    check_error(
        "missing-mesh",
        "    <shape type=\"obj\">\n        <string name=\"filename\" value=\"nope.obj\"/>\n    </shape>\n</scene>\n",
        6,
        &["nope.obj"],
    );
}

#[test]
fn unknown_plugin() {
    check_error(
        "unknown-plugin",
        "    <shape type=\"teapot\"/>\n</scene>\n",
        5,
        &["teapot"],
    );
}

#[test]
fn unknown_bsdf() {
    check_error(
        "unknown-bsdf",
        "    <shape type=\"sphere\">\n        <bsdf type=\"velvet\"/>\n    </shape>\n</scene>\n",
        6,
        &["velvet"],
    );
}

#[test]
fn missing_scene_file() {
    let (code, stderr) = run(&["render", "/definitely/not/here.xml", "-q"]);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("/definitely/not/here.xml") && !stderr.contains("panicked"),
        "{stderr}"
    );
}

#[test]
fn render_writes_exr_png_and_sidecar() {
    let d = tmpdir("ok");
    let scene = d.join("scene.xml");
    std::fs::write(
        &scene,
        format!(
            "{HEADER}    <shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n</scene>\n"
        ),
    )
    .unwrap();
    let out = d.join("out.exr");
    let (code, stderr) = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--spp",
        "4",
        "--png",
        "-q",
        "--aovs",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(out.exists() && d.join("out.png").exists());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out.json")).unwrap()).unwrap();
    assert_eq!(json["spp"], 4);
    assert!(json["samples_per_s"].as_f64().unwrap() > 0.0);
    assert_eq!(json["mean_rgb"].as_array().unwrap().len(), 3);
}
