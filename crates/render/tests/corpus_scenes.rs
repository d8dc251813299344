//! Real public scenes from the shared corpus load and render (few samples, small film) without NaN and
//! with a plausible mean.

mod common;

use common::*;
use focal_render::load::load_scene;
use focal_render::scene::BuildOptions;

fn render_corpus(rel: &str, integrator: Option<&str>) -> [f64; 3] {
    let path = shared_dir().join("corpus").join(rel);
    let opts = BuildOptions {
        integrator_override: integrator.map(str::to_string),
        ..Default::default()
    };
    let mut s = load_scene(&path, &[], &opts).unwrap_or_else(|e| panic!("{e}"));
    // Render a 1/8-size crop of the film quickly.
    s.film.crop_size = s.film.crop_size.min(glam::UVec2::new(96, 72));
    let out = render_loaded(&s, &settings(4, 5, 0));
    assert!(all_finite(&out.image), "{rel}: non-finite pixels");
    let m = out.image.mean_rgb();
    assert!(
        m.iter().all(|c| *c > 1e-4 && *c < 1e3),
        "{rel}: implausible mean {m:?}"
    );
    m
}

#[test]
fn cbox_mitsuba3_renders() {
    render_corpus("cbox-mi3/cbox.xml", None);
}

#[test]
fn cbox_mitsuba05_renders_with_path_override() {
    render_corpus("cbox-mi05/cbox.xml", Some("path"));
}

#[test]
fn cbox_mitsuba05_guided_path_integrator_is_rejected_clearly() {
    let path = shared_dir().join("corpus/cbox-mi05/cbox.xml");
    let err = load_scene(&path, &[], &BuildOptions::default())
        .err()
        .expect("must fail");
    let msg = err.to_string();
    assert!(
        msg.contains("guided_path") && msg.contains("cbox.xml:8:"),
        "{msg}"
    );
}

#[test]
fn veach_mis_renders() {
    render_corpus("veach-mis-mi3/integrator_direct_both.xml", None);
}
