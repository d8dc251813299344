//! A fixed seed gives a bit-identical image whatever the number of threads.

mod common;

use common::*;

#[test]
fn same_seed_same_image_for_any_thread_count() {
    let scene = load(&reference_scene("caustic"), &[("res", "48")]);
    let one = render_loaded(&scene, &settings(6, 42, 1)).image;
    let two = render_loaded(&scene, &settings(6, 42, 2)).image;
    let three = render_loaded(&scene, &settings(6, 42, 3)).image;
    assert!(all_finite(&one));
    assert!(one.rgb == two.rgb, "1 vs 2 threads differ");
    assert!(one.rgb == three.rgb, "1 vs 3 threads differ");
    let other_seed = render_loaded(&scene, &settings(6, 43, 2)).image;
    assert!(
        one.rgb != other_seed.rgb,
        "a different seed must give a different image"
    );
}

#[test]
fn sobol_and_independent_converge_to_the_same_mean() {
    use focal_render::sampler::SamplerKind;
    let scene = load(&reference_scene("cbox"), &[("res", "64")]);
    let mut st = settings(64, 9, 0);
    let indep = render_loaded(&scene, &st).image.mean_rgb();
    st.sampler = SamplerKind::Sobol;
    let sobol = render_loaded(&scene, &st).image.mean_rgb();
    for c in 0..3 {
        assert!(
            (indep[c] - sobol[c]).abs() < 0.01 * indep[c],
            "channel {c}: {} vs {}",
            indep[c],
            sobol[c]
        );
    }
}
