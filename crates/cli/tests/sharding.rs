//! `render --shard I/N` over 4 processes, then `focal merge`, equals one render with 4 times the
//! samples (to float summation order): with a trained guide loaded (the workflow of docs/sharding.md)
//! and for the plain path tracer. Shards draw disjoint samples; wrong shard sets are refused.

mod common;

use common::{cbox, focal};
use focal_render::film::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("focal-shard-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// Renders the 4 shards of `args` + `--spp spp` as 4 processes at once; returns their outputs.
fn render_shards(dir: &Path, args: &[&str], spp: &str) -> Vec<PathBuf> {
    let outputs: Vec<PathBuf> = (0..4).map(|i| dir.join(format!("shard{i}.exr"))).collect();
    let children: Vec<_> = outputs
        .iter()
        .enumerate()
        .map(|(i, out)| {
            Command::new(env!("CARGO_BIN_EXE_focal"))
                .args(args)
                .args(["--spp", spp, "--threads", "1", "-q", "-o", &s(out)])
                .args(["--shard", &format!("{i}/4")])
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for (i, child) in children.into_iter().enumerate() {
        let out = child.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "shard {i}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    outputs
}

/// Every channel of every pixel agrees to float rounding (the summation order differs).
fn assert_same_to_rounding(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut worst = 0.0f64;
    for (x, y) in a.rgb.iter().zip(&b.rgb) {
        for c in 0..3 {
            let (x, y) = (x[c] as f64, y[c] as f64);
            let d = (x - y).abs() / (x.abs().max(y.abs()) + 1e-6);
            worst = worst.max(d);
        }
    }
    eprintln!("largest relative difference {worst:e}");
    assert!(worst < 2e-5, "largest relative difference {worst:e}");
}

fn merge(dir: &Path, inputs: &[PathBuf]) -> Image {
    let out = dir.join("merged.exr");
    let mut args = vec!["merge".to_string()];
    args.extend(inputs.iter().map(|p| s(p)));
    args.extend(["-o".to_string(), s(&out)]);
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    focal(&refs);
    Image::read_exr(&out).unwrap()
}

#[test]
fn four_guided_shards_merge_into_one_render_with_four_times_the_samples() {
    let d = tmpdir("guided");
    let scene = s(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/obscura.xml"));
    let guide = d.join("g.guide");
    focal(&[
        "render",
        &scene,
        "-D",
        "res=16",
        "--guiding",
        "gmm",
        "--spp",
        "16",
        "--save-guide",
        &s(&guide),
        "-o",
        &s(&d.join("train.exr")),
        "-q",
    ]);
    let guide = s(&guide);
    let common_args: [&str; 8] = [
        "render",
        &scene,
        "-D",
        "res=16",
        "--seed",
        "3",
        "--load-guide",
        &guide,
    ];
    let full = d.join("full.exr");
    let full_path = s(&full);
    let mut args: Vec<&str> = common_args.to_vec();
    args.extend(["--spp", "16", "-q", "-o", &full_path]);
    focal(&args);
    let shards = render_shards(&d, &common_args, "4");
    // Disjoint samples: no two shards give the same image.
    let images: Vec<Image> = shards.iter().map(|p| Image::read_exr(p).unwrap()).collect();
    assert_ne!(images[0].rgb, images[1].rgb);
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shards[2].with_extension("json")).unwrap())
            .unwrap();
    assert_eq!(sidecar["shard"]["first_sample"], 8);
    let merged = merge(&d, &shards);
    assert_same_to_rounding(&merged, &Image::read_exr(&full).unwrap());
    let total: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("merged.json")).unwrap()).unwrap();
    assert_eq!(total["spp"], 16);
}

#[test]
fn four_path_traced_shards_merge_into_one_render() {
    let d = tmpdir("plain");
    let cb = s(&cbox());
    let common_args: [&str; 6] = ["render", &cb, "-D", "res=16", "--seed", "5"];
    let full = d.join("full.exr");
    let full_path = s(&full);
    let mut args: Vec<&str> = common_args.to_vec();
    args.extend(["--spp", "8", "-q", "-o", &full_path]);
    focal(&args);
    let shards = render_shards(&d, &common_args, "2");
    assert_same_to_rounding(&merge(&d, &shards), &Image::read_exr(&full).unwrap());

    // Wrong sets of shards are refused; a partial set is merged with a warning.
    let run = |inputs: &[&PathBuf]| {
        let mut args = vec!["merge".to_string()];
        args.extend(inputs.iter().map(|p| s(p)));
        args.extend(["-o".to_string(), s(&d.join("m.exr"))]);
        Command::new(env!("CARGO_BIN_EXE_focal"))
            .args(&args)
            .output()
            .unwrap()
    };
    let twice = run(&[&shards[0], &shards[1], &shards[1]]);
    assert!(!twice.status.success());
    assert!(String::from_utf8_lossy(&twice.stderr).contains("both shard 1/4"));
    let mixed = run(&[&shards[0], &full]);
    assert!(!mixed.status.success());
    assert!(String::from_utf8_lossy(&mixed.stderr).contains("not a shard"));
    let partial = run(&[&shards[0], &shards[3]]);
    assert!(partial.status.success());
    assert!(String::from_utf8_lossy(&partial.stderr).contains("merging 2 of 4 shards"));
}

#[test]
fn shards_need_a_sample_budget_and_a_trained_guide() {
    let d = tmpdir("refused");
    let cb = s(&cbox());
    let out = s(&d.join("o.exr"));
    let refused = |args: &[&str], words: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_focal"))
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(words), "{args:?}: {err}");
    };
    refused(
        &["render", &cb, "--shard", "4/4", "--spp", "1", "-o", &out],
        "0/4 to 3/4",
    );
    refused(
        &["render", &cb, "--shard", "0/4", "--time", "1", "-o", &out],
        "--spp",
    );
    refused(
        &[
            "render",
            &cb,
            "--shard",
            "0/4",
            "--spp",
            "1",
            "--guiding",
            "octree",
            "-o",
            &out,
        ],
        "--load-guide",
    );
}
