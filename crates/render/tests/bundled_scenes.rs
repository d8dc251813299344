//! Every scene bundled in `scenes/` loads and renders: a few samples per pixel at a small resolution give
//! a finite image with a positive mean.

mod common;

use common::*;
use std::path::PathBuf;

fn bundled(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
}

fn renders(name: &str) {
    renders_with(name, &[("res", "24")]);
}

/// The interiors have a 16:9 film of `width` x `height`.
fn interior_renders(name: &str) {
    renders_with(name, &[("width", "32"), ("height", "18")]);
}

fn renders_with(name: &str, defines: &[(&str, &str)]) {
    let scene = load(&bundled(name), defines);
    let out = render_loaded(&scene, &settings(4, 1, 0));
    assert!(all_finite(&out.image), "{name}: non-finite pixels");
    let mean = out.image.mean_rgb();
    assert!(
        mean.iter().all(|&m| m > 0.0 && m.is_finite()),
        "{name}: implausible mean {mean:?}"
    );
}

#[test]
fn cornell_box_renders() {
    renders("cbox.xml");
}

#[test]
fn camera_obscura_renders() {
    renders("obscura.xml");
}

#[test]
fn door_gap_renders() {
    renders("door_gap.xml");
}

#[test]
fn shaded_lights_render() {
    renders("shaded_lights.xml");
}

#[test]
fn lens_focus_renders() {
    renders("lens_focus.xml");
}

#[test]
fn glass_caustic_renders() {
    renders("glass_caustic.xml");
}

#[test]
fn dining_room_renders() {
    interior_renders("dining_room.xml");
}

#[test]
fn stair_hall_renders() {
    interior_renders("stair_hall.xml");
}

#[test]
fn living_room_renders() {
    interior_renders("living_room.xml");
}

#[test]
fn door_ajar_renders() {
    interior_renders("door_ajar.xml");
}

#[test]
fn every_bundled_scene_is_tested() {
    let mut names: Vec<String> = std::fs::read_dir(bundled(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".xml"))
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "cbox.xml",
            "dining_room.xml",
            "door_ajar.xml",
            "door_gap.xml",
            "glass_caustic.xml",
            "lens_focus.xml",
            "living_room.xml",
            "obscura.xml",
            "shaded_lights.xml",
            "stair_hall.xml"
        ]
    );
}
