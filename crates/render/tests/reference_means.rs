//! The path tracer converges to Mitsuba 3's images: image means agree with the reference renders within
//! 3 combined standard errors plus 0.5 %, per channel, and the Cornell box agrees per pixel.

mod common;

use common::*;
use focal_render::film::Image;

fn check_mean(name: &str, json: &str, params: &[(&str, &str)], spp: u32, passes: u32) {
    let scene = load(&reference_scene(name), params);
    let (ours, ours_se) = mean_and_stderr(&scene, spp, passes);
    let (theirs, theirs_se) = mitsuba_mean(json);
    for c in 0..3 {
        let tol = 3.0 * (ours_se[c].powi(2) + theirs_se[c].powi(2)).sqrt() + 0.005 * theirs[c];
        let diff = (ours[c] - theirs[c]).abs();
        eprintln!(
            "{name} channel {c}: focal {:.6} ± {:.6}, mitsuba {:.6} ± {:.6}, |diff| {:.6}, tolerance {:.6}",
            ours[c], ours_se[c], theirs[c], theirs_se[c], diff, tol
        );
        assert!(
            diff <= tol,
            "{name} channel {c}: focal {} vs mitsuba {} (tolerance {tol})",
            ours[c],
            theirs[c]
        );
    }
}

#[test]
fn cornell_box_mean_matches_mitsuba() {
    check_mean(
        "cbox",
        "cbox_llvm_256px_1024spp.json",
        &[("res", "256")],
        16,
        6,
    );
}

#[test]
fn caustic_mean_matches_mitsuba() {
    check_mean(
        "caustic",
        "caustic_llvm_256px_4096spp.json",
        &[("res", "256")],
        16,
        6,
    );
}

#[test]
fn obscura_mean_matches_mitsuba() {
    // Plain path tracing is very noisy here (that is what focal guiding is for): the test is correspondingly
    // loose, but still checks the mean against the reference within the combined standard error.
    check_mean(
        "obscura",
        "obscura_llvm_128px_16384spp.json",
        &[("res", "128")],
        64,
        6,
    );
}

/// relMSE of `a` against `reference` with the usual ε = 1e-2 in the denominator.
fn rel_mse(a: &Image, reference: &Image) -> f64 {
    let mut s = 0.0;
    for (p, r) in a.rgb.iter().zip(&reference.rgb) {
        for c in 0..3 {
            let (x, y) = (p[c] as f64, r[c] as f64);
            s += (x - y).powi(2) / (y * y + 1e-2);
        }
    }
    s / (3 * a.pixel_count()) as f64
}

#[test]
fn cornell_box_per_pixel_error_is_noise() {
    // Two independent renders A and B at n spp. Their mean M has per-pixel variance ≈ (A − B)²/4, and the
    // 1024-spp reference has variance ≈ that × 2n/1024. A bias (misplaced pixels, wrong filter, wrong
    // light) shows up as relMSE(M, ref) well above this noise floor.
    let n = 32;
    let scene = load(&reference_scene("cbox"), &[("res", "256")]);
    let a = render_loaded(&scene, &settings(n, 11, 0)).image;
    let b = render_loaded(&scene, &settings(n, 12, 0)).image;
    let reference =
        Image::read_exr(&test_data_dir().join("references/mitsuba3/cbox_llvm_256px_1024spp.exr"))
            .unwrap();
    assert_eq!((reference.width, reference.height), (a.width, a.height));
    let mut m = a.clone();
    m.add_scaled(&b, 1.0);
    m.scale(0.5);
    let mut noise = 0.0;
    for ((pa, pb), r) in a.rgb.iter().zip(&b.rgb).zip(&reference.rgb) {
        for c in 0..3 {
            let y = r[c] as f64;
            noise += ((pa[c] - pb[c]) as f64).powi(2) / 4.0 / (y * y + 1e-2);
        }
    }
    noise /= (3 * a.pixel_count()) as f64;
    let expected = noise * (1.0 + 2.0 * n as f64 / 1024.0);
    let measured = rel_mse(&m, &reference);
    eprintln!("relMSE(focal {}spp, mitsuba 1024spp) = {measured:.6e}, noise-only expectation {expected:.6e}", 2 * n);
    assert!(
        measured < 1.15 * expected,
        "relMSE {measured} exceeds the noise floor {expected}"
    );
    assert!(
        measured > 0.85 * expected,
        "relMSE {measured} is suspiciously below the noise floor {expected}"
    );
}
