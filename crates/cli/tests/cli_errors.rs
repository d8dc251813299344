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

// ----- issue 42: the bad inputs that did not give a clean error -------------------------------------

mod common;

use common::{cbox, focal};

/// Runs `focal` and returns (exit code, stderr, stdout).
fn run_full(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

/// Asserts a clean failure (exit 1, no panic) whose message has all of `words`.
fn assert_refused(args: &[&str], words: &[&str]) -> String {
    let (code, stderr, _) = run_full(args);
    assert_eq!(code, 1, "{args:?}: exit {code}, stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: panic: {stderr}");
    for w in words {
        assert!(stderr.contains(w), "{args:?}: '{w}' missing in: {stderr}");
    }
    stderr
}

fn s(p: &std::path::Path) -> String {
    p.to_str().unwrap().to_string()
}

/// The obscura scene, whose guides the tests train.
fn obscura() -> String {
    s(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/obscura.xml"))
}

/// Far more samples than a test could render: a command that reaches the render with it never ends, so
/// a refusal that comes back shows the check came before the rendering.
const ENDLESS_SPP: &str = "4000000000";

#[test]
fn infinite_or_huge_time_budgets_are_refused() {
    let d = tmpdir("time");
    let out = s(&d.join("o.exr"));
    for t in ["inf", "1e20", "nan", "-1", "0"] {
        let cb = s(&cbox());
        let time = format!("--time={t}");
        assert_refused(
            &["render", &cb, "-D", "res=8", &time, "-o", &out, "-q"],
            &["--time"],
        );
    }
    assert!(!d.join("o.exr").exists());
}

#[test]
fn a_film_too_large_for_memory_is_refused_before_allocating() {
    // On a machine with more memory than a 65536² film needs this case means nothing (and would try).
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            let l = t
                .lines()
                .find(|l| l.starts_with("MemAvailable:"))?
                .to_string();
            l.split_whitespace().nth(1)?.parse::<u64>().ok()
        })
        .map(|kib| kib * 1024);
    let Some(available) = available else {
        eprintln!("skipped: no /proc/meminfo");
        return;
    };
    if available > 512 << 30 {
        eprintln!("skipped: {available} bytes available");
        return;
    }
    let d = tmpdir("memory");
    let cb = s(&cbox());
    let err = assert_refused(
        &[
            "render",
            &cb,
            "-D",
            "res=65536",
            "-o",
            &s(&d.join("o.exr")),
            "-q",
        ],
        &["65536x65536", "would need about", "GiB", "available"],
    );
    assert!(!err.contains("memory allocation"), "{err}");
}

#[test]
fn thousands_of_nested_bsdfs_are_an_error_with_file_and_line() {
    let mut body = String::from("    <shape type=\"sphere\">\n");
    for _ in 0..5000 {
        body += "<bsdf type=\"twosided\">\n";
    }
    body += &"</bsdf>".repeat(5000);
    body += "\n    </shape>\n</scene>\n";
    // The shape is on line 5, its first nested BSDF on line 6; the 64th plugin deep is refused.
    check_error("deep-nesting", &body, 5 + 64, &["nested more than 64"]);
}

#[test]
fn an_output_name_must_be_exr() {
    let d = tmpdir("ext");
    let cb = s(&cbox());
    for extra in [&[][..], &["--png"][..]] {
        let out = s(&d.join("x.png"));
        let mut args: Vec<&str> =
            vec!["render", &cb, "-D", "res=8", "--spp", "1", "-o", &out, "-q"];
        args.extend(extra);
        assert_refused(&args, &["x.png", ".exr"]);
        assert!(!d.join("x.png").exists() && !d.join("x.json").exists());
    }
    // With the right name, both files are distinct and the sidecar names both.
    let out = d.join("x.exr");
    focal(&[
        "render",
        &cb,
        "-D",
        "res=8",
        "--spp",
        "1",
        "-o",
        &s(&out),
        "--png",
        "-q",
    ]);
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("x.json")).unwrap()).unwrap();
    assert_eq!(sidecar["output"], s(&out));
    assert_eq!(sidecar["png"], s(&d.join("x.png")));
    assert_eq!(
        &std::fs::read(&out).unwrap()[..4],
        &[0x76, 0x2f, 0x31, 0x01]
    );
}

#[test]
fn a_missing_output_folder_is_refused_before_any_work() {
    let d = tmpdir("missing-dir");
    let cb = s(&cbox());
    let missing = "/focal-missing/dir/x.exr";
    assert_refused(
        &["render", &cb, "--spp", ENDLESS_SPP, "-o", missing, "-q"],
        &["/focal-missing/dir", "does not exist"],
    );
    assert_refused(
        &["reference", &cb, "--spp", ENDLESS_SPP, "-o", missing, "-q"],
        &["/focal-missing/dir", "does not exist"],
    );
    // merge checks its output before reading its (here missing) inputs.
    assert_refused(
        &["merge", "/nonexistent-input.exr", "-o", missing],
        &["/focal-missing/dir", "does not exist"],
    );
    // compare: its folder's parent is a file.
    let file = d.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let reference = d.join("ref.exr");
    focal(&[
        "render",
        &cb,
        "-D",
        "res=8",
        "--spp",
        "1",
        "-o",
        &s(&reference),
        "-q",
    ]);
    assert_refused(
        &[
            "compare",
            &cb,
            "-D",
            "res=8",
            "--spp",
            ENDLESS_SPP,
            "--reference",
            &s(&reference),
            "-o",
            &s(&file.join("sub")),
            "--methods",
            "pt",
        ],
        &["a-file", "not a folder"],
    );
}

/// Trains a small guide of `method` on the obscura scene into `dir/NAME.guide`.
fn train_guide(dir: &std::path::Path, method: &str) -> String {
    let guide = s(&dir.join(format!("{method}.guide")));
    let out = s(&dir.join(format!("train-{method}.exr")));
    let ob = obscura();
    focal(&[
        "render",
        &ob,
        "-D",
        "res=8",
        "--guiding",
        method,
        "--spp",
        "8",
        "--save-guide",
        &guide,
        "-o",
        &out,
        "-q",
    ]);
    guide
}

#[test]
fn a_guide_from_another_scene_is_refused_unless_forced() {
    let d = tmpdir("guide-scene");
    let guide = train_guide(&d, "octree");
    let cb = s(&cbox());
    let out = s(&d.join("o.exr"));
    let err = assert_refused(
        &[
            "render",
            &cb,
            "-D",
            "res=8",
            "--spp",
            "2",
            "--load-guide",
            &guide,
            "-o",
            &out,
            "-q",
        ],
        &["obscura.xml", "cbox.xml", "--force-guide"],
    );
    assert!(err.contains("trained on"), "{err}");
    // `reference --load-guide` checks the same binding (before rendering: its spp never ends).
    let reference_out = s(&d.join("ref.exr"));
    assert_refused(
        &[
            "reference",
            &cb,
            "-D",
            "res=8",
            "--spp",
            ENDLESS_SPP,
            "--load-guide",
            &guide,
            "-o",
            &reference_out,
        ],
        &["obscura.xml", "cbox.xml", "--force-guide"],
    );
    // Forced: rendered, with a warning.
    let (code, stderr, _) = run_full(&[
        "render",
        &cb,
        "-D",
        "res=8",
        "--spp",
        "2",
        "--load-guide",
        &guide,
        "--force-guide",
        "-o",
        &out,
        "-q",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("used anyway"), "{stderr}");
    // The same scene at another resolution is the same scene.
    let ob = obscura();
    focal(&[
        "render",
        &ob,
        "-D",
        "res=12",
        "--spp",
        "2",
        "--load-guide",
        &guide,
        "-o",
        &out,
        "-q",
    ]);
}

#[test]
fn a_loaded_guide_brings_its_method() {
    let d = tmpdir("guide-method");
    let guide = train_guide(&d, "gmm");
    let ob = obscura();
    let out = d.join("o.exr");
    assert_refused(
        &[
            "render",
            &ob,
            "-D",
            "res=8",
            "--spp",
            "2",
            "--guiding",
            "octree",
            "--load-guide",
            &guide,
            "-o",
            &s(&out),
            "-q",
        ],
        &["--guiding octree", "gmm guide"],
    );
    // Without --guiding the file's method is used and recorded.
    focal(&[
        "render",
        &ob,
        "-D",
        "res=8",
        "--spp",
        "2",
        "--load-guide",
        &guide,
        "-o",
        &s(&out),
        "-q",
    ]);
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.with_extension("json")).unwrap())
            .unwrap();
    assert_eq!(sidecar["guiding"]["method"], "gmm");
}

#[test]
fn absurd_thread_counts_are_refused_with_the_bound() {
    let d = tmpdir("threads");
    let cb = s(&cbox());
    let out = s(&d.join("o.exr"));
    let cores = std::thread::available_parallelism().unwrap().get();
    let bound = format!("at most {}", 4 * cores);
    assert_refused(
        &[
            "render",
            &cb,
            "-D",
            "res=8",
            "--spp",
            "1",
            "--threads",
            "100000",
            "-o",
            &out,
            "-q",
        ],
        &[&bound, "--threads 100000"],
    );
    assert_refused(
        &[
            "reference",
            &cb,
            "-D",
            "res=8",
            "--spp",
            "1",
            "--threads",
            "100000",
            "-o",
            &out,
            "-q",
        ],
        &[&bound],
    );
    // Every subcommand with --threads documents what 0 means.
    for sub in ["render", "compare", "reference", "fireflies", "bench"] {
        let (_, _, help) = run_full(&[sub, "--help"]);
        let line = help
            .lines()
            .skip_while(|l| !l.contains("--threads"))
            .take(2)
            .collect::<String>();
        assert!(
            line.contains("0") && line.contains("one per core"),
            "{sub}: {line}"
        );
    }
}

#[test]
fn compare_validates_methods_and_reference_before_rendering() {
    let d = tmpdir("compare-validate");
    let cb = s(&cbox());
    let reference = d.join("ref.exr");
    focal(&[
        "render",
        &cb,
        "-D",
        "res=8",
        "--spp",
        "1",
        "-o",
        &s(&reference),
        "-q",
    ]);
    let out = d.join("cmp");
    let base = |methods: &'static str, res: &'static str| {
        vec![
            "compare".to_string(),
            cb.clone(),
            "-D".into(),
            res.into(),
            "--spp".into(),
            ENDLESS_SPP.into(),
            "--reference".into(),
            s(&reference),
            "-o".into(),
            s(&out),
            "--methods".into(),
            methods.into(),
        ]
    };
    let args = base("pt,foo", "res=8");
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    assert_refused(&refs, &["foo", "pt, none, octree, gmm"]);
    assert!(!out.exists(), "a refused compare made its folder");
    let args = base("pt", "res=16");
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    assert_refused(&refs, &["8x8", "16x16"]);
    assert!(!out.exists(), "a refused compare made its folder");
}

// ----- issue 42: consistency of the command line -----------------------------------------------------

#[test]
fn res_sets_the_film_size_of_any_scene_keeping_the_aspect_ratio() {
    let d = tmpdir("res");
    // A 16x8 film without a `res` parameter.
    let scene = d.join("wide.xml");
    std::fs::write(
        &scene,
        HEADER.replace(
            "name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"",
            "name=\"width\" value=\"16\"/><integer name=\"height\" value=\"8\"",
        ) + "</scene>\n",
    )
    .unwrap();
    let size = |res: &str| {
        let out = d.join("o.exr");
        focal(&[
            "render",
            &s(&scene),
            "--res",
            res,
            "--spp",
            "1",
            "--out",
            &s(&out),
            "-q",
        ]);
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("o.json")).unwrap()).unwrap();
        (v["width"].as_u64().unwrap(), v["height"].as_u64().unwrap())
    };
    assert_eq!(size("32"), (32, 16));
    assert_eq!(size("20x10"), (20, 10));
    assert_eq!(size("7X3"), (7, 3));
    for bad in ["0", "x", "10x", "70000", "-4"] {
        let res = format!("--res={bad}");
        assert_refused(
            &[
                "render",
                &s(&scene),
                &res,
                "--spp",
                "1",
                "-o",
                &s(&d.join("b.exr")),
            ],
            &["--res"],
        );
    }
}

#[test]
fn the_sidecar_writes_unlimited_depth_as_minus_one() {
    let d = tmpdir("depth");
    let out = d.join("o.exr");
    focal(&[
        "render",
        &obscura(),
        "-D",
        "res=8",
        "--spp",
        "1",
        "-o",
        &s(&out),
        "-q",
    ]);
    let text = std::fs::read_to_string(d.join("o.json")).unwrap();
    assert!(!text.contains("4294967295"), "{text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["integrator"]["Path"]["max_depth"], -1, "{text}");
}

#[test]
fn json_path_means_the_same_in_every_subcommand() {
    let d = tmpdir("json");
    let cb = s(&cbox());
    let img = d.join("a.exr");
    focal(&[
        "render",
        &cb,
        "-D",
        "res=8",
        "--spp",
        "1",
        "-o",
        &s(&img),
        "-q",
    ]);
    let path = d.join("m.json");
    focal(&["metrics", &s(&img), &s(&img), "--json", &s(&path)]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(v["rel_mse"], 0.0);
    // `-` (or no PATH for metrics) is standard output.
    for args in [&["--json", "-"][..], &["--json"][..]] {
        let mut all: Vec<&str> = vec!["metrics", img.to_str().unwrap(), img.to_str().unwrap()];
        all.extend(args);
        let v: serde_json::Value = serde_json::from_slice(&focal(&all).stdout).unwrap();
        assert_eq!(v["rel_mse"], 0.0);
    }
    assert_refused(
        &[
            "metrics",
            &s(&img),
            &s(&img),
            "--json",
            "/focal-missing/m.json",
        ],
        &["does not exist"],
    );
}

#[test]
fn fireflies_shows_only_its_options_and_requires_the_guide() {
    let (_, _, help) = run_full(&["fireflies", "--help"]);
    for used in [
        "--load-guide <PATH>",
        "--guide-fraction",
        "--rr",
        "--no-split",
        "--force-guide",
    ] {
        assert!(help.contains(used), "{used} missing: {help}");
    }
    for unused in [
        "--save-guide",
        "--iterations",
        "--train-fraction",
        "--combine",
        "--guiding ",
    ] {
        let shown = help.lines().any(|l| l.trim_start().starts_with(unused));
        assert!(!shown, "{unused} shown: {help}");
    }
    let (code, stderr, _) = run_full(&["fireflies", "x.xml", "--reference", "r.exr", "--spp", "1"]);
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("--load-guide"), "{stderr}");
}
