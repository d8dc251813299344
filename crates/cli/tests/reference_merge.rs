//! `focal reference` resumes after an interruption (a deliberate stop, and a real SIGKILL of the
//! process) to the bit-identical image of an uninterrupted run; `focal merge` weights by sample count.

use focal_render::film::Image;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod common;

use common::{cbox as scene, focal};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("focal-refmerge-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn reference_args<'a>(out: &'a str, spp: &'a str) -> Vec<&'a str> {
    let s = scene();
    let s: &'static str = Box::leak(s.to_str().unwrap().to_string().into_boxed_str());
    vec![
        "reference",
        s,
        "-D",
        "res=16",
        "--spp",
        spp,
        "--pass-spp",
        "4",
        "--checkpoint-every",
        "0",
        "-q",
        "-o",
        out,
    ]
}

fn read(p: &Path) -> Image {
    Image::read_exr(p).unwrap()
}

fn assert_bit_identical(a: &Image, b: &Image) {
    assert_eq!(a.rgb.len(), b.rgb.len());
    for (x, y) in a.rgb.iter().zip(&b.rgb) {
        assert_eq!(x.map(f32::to_bits), y.map(f32::to_bits));
    }
    assert_eq!(a.layers.len(), b.layers.len());
    for (la, lb) in a.layers.iter().zip(&b.layers) {
        assert_eq!(la.name, lb.name);
        let bits = |l: &[f32]| l.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&la.data), bits(&lb.data));
    }
}

#[test]
fn reference_resumes_bit_identically_after_a_stop() {
    let d = tmpdir("stop");
    let full = d.join("full.exr");
    focal(&reference_args(full.to_str().unwrap(), "24"));
    let part = d.join("part.exr");
    let mut args = reference_args(part.to_str().unwrap(), "24");
    args.extend(["--stop-after-passes", "2"]);
    focal(&args);
    assert!(!part.exists(), "a stopped render writes no image");
    assert!(d.join("part.exr.checkpoint").exists());
    // Resumed with another thread count: still the same image.
    let mut args = reference_args(part.to_str().unwrap(), "24");
    args.extend(["--threads", "1"]);
    focal(&args);
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("part.json")).unwrap()).unwrap();
    assert_eq!(sidecar["resumed_from_spp"], 8);
    assert_eq!(sidecar["spp"], 24);
    let (a, b) = (read(&full), read(&part));
    assert_bit_identical(&a, &b);
    // The variance layer exists, is finite and not all zero (6 passes of a noisy render).
    let var = a.layer("variance").expect("variance layer");
    assert!(var.data.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(var.data.iter().any(|v| *v > 0.0));
    // Another scene setting is refused instead of silently mixing samples.
    let mut args = reference_args(part.to_str().unwrap(), "32");
    args[3] = "res=8";
    let out = Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(&args)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("checkpoint"));
}

#[test]
fn reference_resumes_bit_identically_after_sigkill() {
    let d = tmpdir("kill");
    let spp = "400";
    let full = d.join("full.exr");
    focal(&reference_args(full.to_str().unwrap(), spp));
    let part = d.join("part.exr");
    let checkpoint = d.join("part.exr.checkpoint");
    let mut child = Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(reference_args(part.to_str().unwrap(), spp))
        .args(["--threads", "1"])
        .spawn()
        .unwrap();
    // Kill it as soon as a first checkpoint exists.
    let start = Instant::now();
    while !checkpoint.exists() && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = child.kill(); // SIGKILL on Unix
    let _ = child.wait();
    assert!(checkpoint.exists(), "no checkpoint was written");
    focal(&reference_args(part.to_str().unwrap(), spp));
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("part.json")).unwrap()).unwrap();
    let resumed = sidecar["resumed_from_spp"].as_u64().unwrap();
    assert!(
        resumed > 0 && resumed < 400,
        "the kill did not interrupt the render (resumed from {resumed} spp)"
    );
    assert_bit_identical(&read(&full), &read(&part));
}

fn write_render(dir: &Path, name: &str, value: [f32; 3], spp: u64, size: u32) -> PathBuf {
    let mut img = Image::new(size, 1);
    img.rgb.fill(value);
    let p = dir.join(format!("{name}.exr"));
    img.write_exr(&p).unwrap();
    std::fs::write(
        p.with_extension("json"),
        serde_json::json!({"spp": spp, "seed": name, "scene": "s.xml"}).to_string(),
    )
    .unwrap();
    p
}

#[test]
fn merge_weights_by_sample_count_and_reports_mismatches() {
    let d = tmpdir("merge");
    let a = write_render(&d, "a", [4.0, 2.0, 0.0], 1, 2);
    let b = write_render(&d, "b", [0.0, 2.0, 4.0], 3, 2);
    let out = d.join("m.exr");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    focal(&["merge", &s(&a), &s(&b), "-o", &s(&out)]);
    // (1·4 + 3·0)/4 = 1, 2, (1·0 + 3·4)/4 = 3.
    assert_eq!(read(&out).rgb, vec![[1.0, 2.0, 3.0]; 2]);
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.with_extension("json")).unwrap())
            .unwrap();
    assert_eq!(sidecar["spp"], 4);
    // A merged render merges again with its total weight: (4·[1,2,3] + 4·[1,1,1]) / 8.
    let c = write_render(&d, "c", [1.0, 1.0, 1.0], 4, 2);
    let out2 = d.join("m2.exr");
    focal(&["merge", &s(&out), &s(&c), "-o", &s(&out2)]);
    assert_eq!(read(&out2).rgb, vec![[1.0, 1.5, 2.0]; 2]);

    let fail = |args: &[&str], words: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_focal"))
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(words),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    };
    let wide = write_render(&d, "wide", [1.0; 3], 1, 3);
    fail(&["merge", &s(&a), &s(&wide), "-o", &s(&out)], "3x1");
    std::fs::remove_file(b.with_extension("json")).unwrap();
    fail(&["merge", &s(&a), &s(&b), "-o", &s(&out)], "sidecar");
}
