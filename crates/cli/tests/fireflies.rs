//! `focal fireflies` lists the highest-scoring samples of a render with a trained guide, each with a
//! path record whose light adds up to the sample's value, the same for any number of threads.

mod common;

use common::focal;
use focal_render::film::Image;
use std::path::Path;

#[test]
fn fireflies_are_ranked_complete_and_deterministic() {
    let d = std::env::temp_dir().join(format!("focal_fireflies_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/glass_caustic.xml");
    let scene = scene.to_str().unwrap();
    let guide = d.join("guide.bin");
    let reference = d.join("reference.exr");
    focal(&[
        "render",
        scene,
        "-D",
        "res=24",
        "--guiding",
        "gmm",
        "--spp",
        "32",
        "--no-fallback",
        "--save-guide",
        guide.to_str().unwrap(),
        "-q",
        "-o",
        reference.to_str().unwrap(),
    ]);
    // The same fireflies search against `reference`, with `threads` workers; its JSON report.
    let run = |reference: &Path, threads: &str, json: &Path| {
        focal(&[
            "fireflies",
            scene,
            "-D",
            "res=24",
            "--load-guide",
            guide.to_str().unwrap(),
            "--reference",
            reference.to_str().unwrap(),
            "--spp",
            "4",
            "--seed",
            "7",
            "--top",
            "8",
            "--threads",
            threads,
            "--json",
            json.to_str().unwrap(),
        ]);
        std::fs::read_to_string(json).unwrap()
    };
    let one = run(&reference, "1", &d.join("one.json"));
    let two = run(&reference, "2", &d.join("two.json"));
    assert_eq!(one, two, "the report depends on the thread count");

    let report: serde_json::Value = serde_json::from_str(&one).unwrap();
    let list = report["fireflies"].as_array().unwrap();
    assert_eq!(list.len(), 8);
    let share = report["top_share"].as_f64().unwrap();
    assert!(share > 0.0 && share <= 1.0, "{share}");
    assert!(report["implied_rel_mse"].as_f64().unwrap() > 0.0);
    let scores: Vec<f64> = list.iter().map(|f| f["score"].as_f64().unwrap()).collect();
    assert!(scores.windows(2).all(|w| w[0] >= w[1]), "{scores:?}");
    for f in list {
        let trace = &f["trace"];
        // The lights recorded add up to the sample's value: nothing the path added is missing.
        let lights: f64 = trace["lights"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| l["value"].as_f64().unwrap())
            .sum();
        let value = f["value"].as_f64().unwrap();
        assert!(
            (lights - value).abs() <= 1e-4 * value.abs().max(1e-6),
            "lights {lights} against the sample's value {value}: {f}"
        );
        // Vertices are recorded once each, in order: the camera path's from depth 0, each split-off
        // copy's at consecutive depths.
        let vertices = trace["vertices"].as_array().unwrap();
        let camera_path = vertices.iter().filter(|v| v["branch"].as_u64() == Some(0));
        for (i, v) in camera_path.enumerate() {
            assert_eq!(v["depth"].as_u64().unwrap(), i as u64, "{f}");
        }
        for w in vertices.windows(2) {
            if w[0]["branch"] == w[1]["branch"] {
                let d = |v: &serde_json::Value| v["depth"].as_u64().unwrap();
                assert_eq!(d(&w[1]), d(&w[0]) + 1, "{f}");
            }
        }
    }

    // A reference pixel holding NaN reads as 0, as relMSE reads it: every score stays finite and the
    // report is the one a zero there gives, instead of a NaN score sorting first.
    let poisoned = |value: f32, name: &str| {
        let mut image = Image::read_exr(&reference).unwrap();
        image.rgb[5 * image.width as usize + 7] = [value, 0.0, value];
        let path = d.join(name);
        image.write_exr(&path).unwrap();
        run(&path, "2", &d.join(format!("{name}.json")))
    };
    let with_nan = poisoned(f32::NAN, "nan.exr");
    let report: serde_json::Value = serde_json::from_str(&with_nan).unwrap();
    let total = report["total_score"].as_f64().unwrap();
    assert!(total.is_finite(), "{total}");
    let first = report["fireflies"][0]["score"].as_f64().unwrap();
    assert!(first.is_finite(), "{first}");
    assert_eq!(with_nan, poisoned(0.0, "zero.exr"));
    let _ = std::fs::remove_dir_all(&d);
}
