//! The interiors under the default guided render: rooms lit through small openings (bulbs inside
//! shades, up-lighters behind slots, a lamp shade and a small window, a door ajar), where an image that
//! missed the light is quiet and dark. No default octree run, over eight seeds, may come out black: the
//! fallback must not give guiding up on the evidence of samples that missed the light, and the
//! combination must not hand the weight to the iterations that found nothing.

mod common;

use common::*;
use focal_render::eval::score::{trimmed_brightness, TRIM_FRACTION};
use focal_render::guide::{make_guide, GuideParams, GuidingMethod};
use focal_render::integrator::GuidedSettings;
use focal_render::render::combine::Combine;
use focal_render::render::guided::{render_guided, GuidedRenderSettings, TrainingBudget};
use std::path::PathBuf;

fn interior(name: &str) -> focal_render::scene::LoadedScene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    load(&path, &[("width", "48"), ("height", "27")])
}

/// Renders `name` with the octree's default time-budget schedule (1 s) for seeds 0–7 and checks every
/// image's mean brightness, brightest 0.1 % of pixels left out, against a path-traced reference's; the
/// failure, if any.
fn never_black(name: &str) -> Option<String> {
    let scene = interior(name);
    let reference = render_loaded(&scene, &settings(512, 0x5eed, 0)).image;
    let truth = trimmed_brightness(&reference, TRIM_FRACTION);
    if !(truth > 0.0) {
        return Some(format!("{name}: black reference"));
    }
    let mut ratios = Vec::new();
    let mut fell_back = 0;
    for seed in 0..8 {
        let mut guide = make_guide(
            GuidingMethod::Octree,
            &scene.scene.bounds,
            &GuideParams::default(),
        )
        .unwrap()
        .unwrap();
        let s = GuidedRenderSettings {
            render: settings(1 << 16, seed, 0),
            integrator: GuidedSettings::default(),
            budget: TrainingBudget::Time {
                seconds: 1.0,
                training_fraction: 0.5,
                iterations: 15,
                max_spp: 1 << 16,
            },
            combine: Combine::InverseVariance,
            pretrained: false,
            fallback: true,
        };
        let out = render_guided(
            &scene.scene,
            &scene.camera,
            &scene.film,
            Some(guide.as_mut()),
            &s,
            &|_| {},
        );
        ratios.push(trimmed_brightness(&out.image, TRIM_FRACTION) / truth);
        fell_back += out.fallback.is_some_and(|f| f.fell_back) as u32;
    }
    (!ratios.iter().all(|&r| r > 0.5)).then(|| {
        format!("{name}: trimmed image means over the reference's {ratios:?} ({fell_back} of 8 gave guiding up)")
    })
}

/// One test for the four rooms, rendered one after the other: a time budget shared with other tests
/// running in parallel would leave each render too few samples to say anything.
#[test]
fn no_default_octree_render_of_an_interior_is_black() {
    let failures: Vec<String> = [
        "dining_room.xml",
        "stair_hall.xml",
        "living_room.xml",
        "door_ajar.xml",
    ]
    .into_iter()
    .filter_map(never_black)
    .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
