//! Fuzzing of the command line (proptest over argument vectors): whatever the arguments, `focal` exits
//! with 0 (done), 1 (a clear error) or 2 (clap's usage error), never with a panic (101) or a signal
//! (an abort, a stack overflow). Runs are kept tiny: 4-pixel films, 1 spp unless the case gives its own
//! (small or invalid) budget, and a capped number of cases (`FOCAL_FUZZ_CASES`, default 40).

mod common;

use common::{cbox, focal};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// A folder with the files the cases name: a reference, a guide, a garbage file.
fn fixtures() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("focal-cli-fuzz-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let cb = cbox();
        let obscura = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/obscura.xml");
        let p = |name: &str| d.join(name).to_str().unwrap().to_string();
        focal(&[
            "render",
            cb.to_str().unwrap(),
            "-D",
            "res=4",
            "--spp",
            "2",
            "-q",
            "-o",
            &p("ref.exr"),
        ]);
        focal(&[
            "render",
            obscura.to_str().unwrap(),
            "-D",
            "res=4",
            "--guiding",
            "octree",
            "--spp",
            "4",
            "--save-guide",
            &p("g.guide"),
            "-q",
            "-o",
            &p("train.exr"),
        ]);
        std::fs::write(
            d.join("garbage.xml"),
            "<scene version=\"3.0.0\"><shape type=",
        )
        .unwrap();
        std::fs::write(d.join("garbage.exr"), "not an image").unwrap();
        d
    })
}

fn fixture(name: &str) -> String {
    fixtures().join(name).to_str().unwrap().to_string()
}

/// Option tokens and the values a case may give them (valid, borderline and absurd).
fn option() -> impl Strategy<Value = Vec<String>> {
    let flag = |f: &'static str, values: &'static [&'static str]| {
        proptest::sample::select(values).prop_map(move |v| vec![f.to_string(), v.to_string()])
    };
    prop_oneof![
        flag("--spp", &["0", "1", "2", "-1", "abc", "4294967296"]),
        flag("--time", &["0", "-1", "inf", "nan", "1e20", "0.05", "abc"]),
        flag("--threads", &["0", "1", "2", "100000", "-1"]),
        flag(
            "-D",
            &[
                "res=4",
                "res=0",
                "res=-3",
                "res=65536",
                "res=abc",
                "nope=1",
                "=",
                "res"
            ]
        ),
        flag("--res", &["4", "4x2", "0", "x", "70000", "3x0"]),
        flag("--seed", &["0", "18446744073709551615", "-5", "0x10"]),
        flag("--guiding", &["octree", "gmm", "none", "foo"]),
        flag("--combine", &["variance", "last", "foo"]),
        flag("--iterations", &["0", "1", "4294967295"]),
        flag("--train-fraction", &["0", "1", "2", "nan"]),
        flag("--guide-fraction", &["0", "0.5", "1", "-1", "nan"]),
        flag("--rr", &["albedo", "off", "foo"]),
        flag("--sampler", &["independent", "sobol", "foo"]),
        flag("--shard", &["0/2", "1/2", "2/2", "x", "0/0"]),
        flag("--gmm", &["k_max=0", "k_max=4", "nope=1", "k_max=x"]),
        flag("--octree-threshold", &["0", "-1", "nan", "0.01"]),
        flag("--exposure", &["0", "nan", "inf"]),
        flag("--methods", &["pt", "pt,foo", "gmm,gmm", ""]),
        flag("--seeds", &["0", "1", "2"]),
        flag("--curve-points", &["0", "1", "2", "99"]),
        flag("--epsilon", &["0", "-1", "0.01", "nan"]),
        flag("--outliers", &["0", "0.5", "1", "-1"]),
        flag("--pass-spp", &["0", "1", "4"]),
        flag("--integrator", &["path", "foo"]),
        Just(vec!["--png".to_string()]),
        Just(vec!["--aovs".to_string()]),
        Just(vec!["--lenient".to_string()]),
        Just(vec!["--no-fallback".to_string()]),
        Just(vec!["--guide-image".to_string()]),
        Just(vec!["--force-guide".to_string()]),
        Just(vec!["--bogus".to_string()]),
        Just(vec!["-o".to_string(), "x.png".to_string()]),
        Just(vec!["-o".to_string(), "/focal-missing/x.exr".to_string()]),
        Just(vec!["--load-guide".to_string(), fixture("g.guide")]),
        Just(vec!["--load-guide".to_string(), fixture("garbage.exr")]),
        Just(vec!["--reference".to_string(), fixture("garbage.exr")]),
        Just(vec!["--json".to_string(), "-".to_string()]),
    ]
}

/// A subcommand, its positional arguments and a few options.
fn case() -> impl Strategy<Value = Vec<String>> {
    let scene = proptest::sample::select(vec![
        cbox().to_str().unwrap().to_string(),
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes/obscura.xml")
            .to_str()
            .unwrap()
            .to_string(),
        fixture("garbage.xml"),
        "/focal-missing.xml".to_string(),
    ]);
    let sub = proptest::sample::select(vec![
        "render",
        "render",
        "render",
        "reference",
        "compare",
        "merge",
        "metrics",
        "fireflies",
    ]);
    (sub, scene, proptest::collection::vec(option(), 0..6)).prop_map(|(sub, scene, opts)| {
        let mut args = vec![sub.to_string()];
        match sub {
            "merge" => args.push(fixture("ref.exr")),
            "metrics" => {
                args.push(fixture("ref.exr"));
                args.push(fixture("ref.exr"));
            }
            _ => args.push(scene),
        }
        args.extend(opts.into_iter().flatten());
        args
    })
}

/// Completes a case so that whatever renders stays tiny, and gives it a fresh output path.
fn bounded(mut args: Vec<String>, case_dir: &Path) -> Vec<String> {
    let has = |args: &[String], f: &str| args.iter().any(|a| a == f || a.starts_with(f));
    let sub = args[0].clone();
    if matches!(
        sub.as_str(),
        "render" | "reference" | "compare" | "fireflies"
    ) {
        if !has(&args, "--spp") {
            args.extend(["--spp".into(), "1".into()]);
        }
        if !args.iter().any(|a| a.starts_with("res=")) && !has(&args, "--res") {
            args.extend(["--res".into(), "4".into()]);
        }
        if !has(&args, "--threads") {
            args.extend(["--threads".into(), "1".into()]);
        }
    }
    if matches!(sub.as_str(), "compare" | "fireflies") && !has(&args, "--reference") {
        args.extend(["--reference".into(), fixture("ref.exr")]);
    }
    if sub == "compare" && !has(&args, "--curve-points") {
        args.extend(["--curve-points".into(), "1".into()]);
    }
    if sub == "fireflies" && !has(&args, "--load-guide") {
        args.extend(["--load-guide".into(), fixture("g.guide")]);
    }
    if sub == "render" || sub == "reference" {
        args.push("-q".into());
    }
    if sub != "metrics" && sub != "fireflies" && !has(&args, "-o") {
        let out = if sub == "compare" { "cmp" } else { "out.exr" };
        args.extend([
            "-o".into(),
            case_dir.join(out).to_str().unwrap().to_string(),
        ]);
    }
    args
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("FOCAL_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(40),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn no_argument_vector_panics_or_aborts(args in case()) {
        let case_dir = fixtures().join(format!("case-{}", rand_suffix(&args)));
        std::fs::create_dir_all(&case_dir).unwrap();
        let args = bounded(args, &case_dir);
        let out = Command::new(env!("CARGO_BIN_EXE_focal"))
            .args(&args)
            .current_dir(&case_dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let code = out.status.code();
        prop_assert!(code.is_some(), "{args:?}: killed by a signal ({:?}): {stderr}", out.status);
        prop_assert!(matches!(code, Some(0..=2)), "{args:?}: exit {code:?}: {stderr}");
        prop_assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        if code == Some(1) {
            prop_assert!(stderr.contains("error:"), "{args:?}: no message: {stderr}");
        }
        let _ = std::fs::remove_dir_all(&case_dir);
    }
}

/// A short name for a case's folder (cases run one after another; the name only avoids clashes with
/// leftovers).
fn rand_suffix(args: &[String]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    args.hash(&mut h);
    h.finish()
}
