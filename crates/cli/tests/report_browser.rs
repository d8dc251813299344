//! The `focal compare` report opens in a real browser (headless Chromium) without console messages,
//! and its slider switches between images (the page's own `#selftest`, driven through its controls).
//!
//! Needs Debian's `chromium` (`.ci/run` installs it); without it the test says so loudly and skips,
//! except under CI (`CI` set), where a missing browser is a failure.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{cbox, focal};

fn chromium() -> Option<PathBuf> {
    ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.exists())
}

#[test]
fn report_opens_in_chromium_and_its_slider_switches_images() {
    let Some(browser) = chromium() else {
        if std::env::var_os("CI").is_some() {
            panic!("chromium is missing under CI: .ci/run must install it");
        }
        eprintln!(
            "\n*** SKIPPED report_opens_in_chromium: /usr/bin/chromium not found \
             (apt-get install -y chromium) ***\n"
        );
        return;
    };
    let d = std::env::temp_dir().join(format!("focal-report-browser-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let scene = cbox();
    let scene = scene.to_str().unwrap();
    let reference = d.join("ref.exr");
    let r = reference.to_str().unwrap();
    focal(&[
        "reference",
        scene,
        "-D",
        "res=16",
        "--spp",
        "32",
        "--pass-spp",
        "8",
        "-q",
        "-o",
        r,
    ]);
    let out = d.join("report");
    let o = out.to_str().unwrap();
    focal(&[
        "compare",
        scene,
        "-D",
        "res=16",
        "--spp",
        "4",
        "--methods",
        "pt,octree",
        "--curve-points",
        "2",
        "--reference",
        r,
        "--out",
        o,
    ]);
    for f in [
        "index.html",
        "convergence_time.svg",
        "convergence_spp.svg",
        "data/reference.js",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let url = format!("file://{}#selftest", out.join("index.html").display());
    let profile = d.join("chromium-profile");
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(&url)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("chromium did not finish in 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let output = child.wait_with_output().unwrap();
    let dom = String::from_utf8_lossy(&output.stdout);
    let log = String::from_utf8_lossy(&output.stderr);
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:#?}");
    let status = dom
        .split("<pre id=\"selftest\">")
        .nth(1)
        .and_then(|s| s.split("</pre>").next())
        .unwrap_or("");
    assert!(
        status.starts_with("SELFTEST PASS (3 images)"),
        "self-test: {status:?}\nchromium log:\n{log}"
    );
    assert!(dom.contains("<table id=\"metrics\">") && dom.contains("<td>octree</td>"));
    let _ = std::fs::remove_dir_all(&d);
}
