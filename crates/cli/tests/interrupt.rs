//! Ctrl-C (a real SIGINT sent to a child process) stops a render at the next pass and keeps the work:
//! the image of the finished passes, a sidecar with the true spp and `interrupted: true`, exit code 130.
//! A guided render combines its finished iterations; `compare` keeps and reports its finished runs; a
//! second Ctrl-C aborts at once.
#![cfg(target_os = "linux")]

mod common;

use common::cbox;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("focal-interrupt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// CPU seconds the process has used (Linux /proc), which tells that it is rendering, however loaded
/// the machine is.
fn cpu_seconds(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or(vec![], |(_, rest)| rest.split_whitespace().collect());
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 after the name.
    (ticks(11) + ticks(12)) / 100.0
}

/// Waits until `cond` holds (or a minute has passed).
fn wait_for(mut cond: impl FnMut() -> bool) {
    let start = Instant::now();
    while !cond() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn sigint(child: &Child) {
    let ok = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -INT failed");
}

/// Waits for the child (at most two minutes) and returns its exit code and stderr.
fn finish(mut child: Child) -> (i32, String) {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let out = child.wait_with_output().unwrap();
            return (
                status.code().unwrap_or(-1),
                String::from_utf8_lossy(&out.stderr).into_owned(),
            );
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("the interrupted process did not stop");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn sidecar(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p.with_extension("json")).unwrap()).unwrap()
}

/// Far more samples than a test could render.
const ENDLESS_SPP: &str = "4000000000";

#[test]
fn sigint_writes_the_finished_passes_and_exits_130() {
    let d = tmpdir("plain");
    let out = d.join("o.exr");
    let cb = s(&cbox());
    let child = spawn(&[
        "render",
        &cb,
        "-D",
        "res=32",
        "--spp",
        ENDLESS_SPP,
        "--threads",
        "1",
        "-o",
        &s(&out),
        "-q",
    ]);
    let pid = child.id();
    wait_for(|| cpu_seconds(pid) >= 1.0);
    sigint(&child);
    let (code, stderr) = finish(child);
    assert_eq!(code, 130, "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let v = sidecar(&out);
    assert_eq!(v["interrupted"], true);
    let spp = v["spp"].as_u64().unwrap();
    assert!(spp > 0 && spp < 4_000_000_000, "spp {spp}");
    let image = focal_render::film::Image::read_exr(&out).unwrap();
    assert!(image.rgb.iter().flatten().all(|v| v.is_finite()));
    assert!(
        image.mean_rgb()[0] > 0.0,
        "an interrupted render wrote a black image"
    );
}

#[test]
fn sigint_during_a_guided_render_combines_the_finished_iterations() {
    let d = tmpdir("guided");
    let out = d.join("o.exr");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/obscura.xml");
    let guide = d.join("g.guide");
    let child = spawn(&[
        "render",
        &s(&scene),
        "-D",
        "res=16",
        "--guiding",
        "octree",
        "--spp",
        ENDLESS_SPP,
        "--threads",
        "1",
        "--save-guide",
        &s(&guide),
        "-o",
        &s(&out),
        "-q",
    ]);
    let pid = child.id();
    wait_for(|| cpu_seconds(pid) >= 2.0);
    sigint(&child);
    let (code, stderr) = finish(child);
    assert_eq!(code, 130, "{stderr}");
    let v = sidecar(&out);
    assert_eq!(v["interrupted"], true);
    let iterations = v["iterations"].as_array().unwrap();
    assert!(iterations.len() >= 2, "{iterations:?}");
    let spp: u64 = iterations.iter().map(|i| i["spp"].as_u64().unwrap()).sum();
    assert_eq!(v["spp"].as_u64().unwrap(), spp);
    let weights: f64 = iterations
        .iter()
        .map(|i| i["weight"].as_f64().unwrap())
        .sum();
    assert!((weights - 1.0).abs() < 1e-9, "weights sum to {weights}");
    // The interrupted training did not save a guide as if it were trained.
    assert!(!guide.exists());
    assert!(stderr.contains("not saved"), "{stderr}");
}

#[test]
fn a_second_sigint_aborts_at_once() {
    let d = tmpdir("twice");
    let out = d.join("o.exr");
    let cb = s(&cbox());
    let child = spawn(&[
        "render",
        &cb,
        "-D",
        "res=32",
        "--spp",
        ENDLESS_SPP,
        "--threads",
        "1",
        "-o",
        &s(&out),
        "-q",
    ]);
    let pid = child.id();
    wait_for(|| cpu_seconds(pid) >= 0.5);
    sigint(&child);
    sigint(&child);
    let (code, stderr) = finish(child);
    assert_eq!(code, 130, "{stderr}");
    assert!(
        stderr.contains("aborting") || stderr.contains("interrupted"),
        "{stderr}"
    );
}

#[test]
fn sigint_during_compare_keeps_the_finished_runs() {
    let d = tmpdir("compare");
    let cb = s(&cbox());
    let reference = d.join("ref.exr");
    common::focal(&[
        "render",
        &cb,
        "-D",
        "res=8",
        "--spp",
        "16",
        "-o",
        &s(&reference),
        "-q",
    ]);
    let out = d.join("cmp");
    let child = spawn(&[
        "compare",
        &cb,
        "-D",
        "res=8",
        "--time",
        "3",
        "--reference",
        &s(&reference),
        "--methods",
        "pt,octree",
        "--curve-points",
        "1",
        "--threads",
        "1",
        "-o",
        &s(&out),
    ]);
    // Interrupted during the octree's run (3 s), after the path tracer's has finished.
    let pt = out.join("pt_s0.json");
    wait_for(|| pt.exists());
    std::thread::sleep(Duration::from_millis(500));
    sigint(&child);
    let (code, stderr) = finish(child);
    assert_eq!(code, 130, "{stderr}");
    let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert!(csv.lines().any(|l| l.starts_with("pt,0,")), "{csv}");
    assert!(
        !csv.contains("octree"),
        "the interrupted run was judged: {csv}"
    );
    assert!(out.join("index.html").exists());
}
