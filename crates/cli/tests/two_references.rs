//! With two independent noisy references, `focal metrics --second-reference` finds an image's error
//! against the true image (here: a reference with 32× the samples), where one noisy reference inflates
//! it; `focal compare --second-reference` reports the same estimate per run.

mod common;

use common::{cbox, focal};
use std::path::{Path, PathBuf};

fn scene() -> String {
    cbox().to_str().unwrap().to_string()
}

/// A path-traced Cornell box of 32×32 pixels at `spp` with `seed`.
fn render(dir: &Path, name: &str, spp: u32, seed: u32) -> PathBuf {
    let out = dir.join(format!("{name}.exr"));
    let (spp, seed) = (spp.to_string(), seed.to_string());
    focal(&[
        "reference",
        &scene(),
        "-D",
        "res=32",
        "--spp",
        &spp,
        "--pass-spp",
        "16",
        "--checkpoint-every",
        "0",
        "--seed",
        &seed,
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    out
}

/// A CSV file's text and the values of its `rel_mse_two_references` column, row by row.
fn two_reference_column(path: &Path) -> (String, Vec<f64>) {
    let csv = std::fs::read_to_string(path).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = header
        .iter()
        .position(|h| *h == "rel_mse_two_references")
        .unwrap_or_else(|| panic!("no two-reference column in {}", path.display()));
    let values = lines
        .map(|l| l.split(',').nth(column).unwrap().parse().unwrap())
        .collect();
    (csv, values)
}

fn metrics(image: &Path, reference: &Path, second: Option<&Path>) -> serde_json::Value {
    let mut args = vec![
        "metrics",
        image.to_str().unwrap(),
        reference.to_str().unwrap(),
        "--json",
    ];
    if let Some(s) = second {
        args.extend(["--second-reference", s.to_str().unwrap()]);
    }
    serde_json::from_slice(&focal(&args).stdout).unwrap()
}

#[test]
fn two_noisy_references_recover_the_error_against_a_far_better_one() {
    let d = std::env::temp_dir().join(format!("focal-two-refs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let image = render(&d, "image", 32, 1);
    let a = render(&d, "a", 32, 2);
    let b = render(&d, "b", 32, 3);
    let truth = render(&d, "truth", 1024, 4);
    let against_truth = metrics(&image, &truth, None)["rel_mse"].as_f64().unwrap();
    let one = metrics(&image, &a, None);
    let against_a = one["rel_mse"].as_f64().unwrap();
    let two = metrics(&image, &a, Some(&b));
    let estimate = two["rel_mse_two_references"].as_f64().unwrap();
    // References as noisy as the image double its apparent error; the two-reference estimate does not
    // (the long reference still holds 1/32 of the image's variance, and 1024 pixels leave some noise).
    assert!(
        against_a > 1.6 * against_truth,
        "{against_a} {against_truth}"
    );
    assert!(
        (estimate / against_truth - 1.0).abs() < 0.25,
        "two-reference estimate {estimate}, against the long reference {against_truth}, \
         against one short reference {against_a}"
    );
    assert!(one.get("rel_mse_two_references").is_none());

    let out = d.join("compare");
    focal(&[
        "compare",
        &scene(),
        "-D",
        "res=32",
        "--spp",
        "8",
        "--methods",
        "pt",
        "--curve-points",
        "2",
        "--reference",
        a.to_str().unwrap(),
        "--second-reference",
        b.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let (csv, values) = two_reference_column(&out.join("metrics.csv"));
    let value = values[0];
    assert!(value.is_finite() && value > 0.0, "{csv}");
    // The convergence curve's smaller run is judged against the truth too.
    let (curve, values) = two_reference_column(&out.join("convergence.csv"));
    assert_eq!(values.len(), 2, "{curve}");
    // Half the samples: about twice the error against the truth.
    assert!(values[0] > 1.3 * values[1], "{curve}");
    let _ = std::fs::remove_dir_all(&d);
}
