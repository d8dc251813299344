//! Fit-time measurement for a million training rays (ignored by default; run with
//! `cargo test -p focal-guiding --release --test gmm_timing -- --ignored --nocapture`).

mod gmm_common;

use focal_guiding::gmm::{GmmConfig, GmmGuide};
use focal_guiding::GuidingField;
use glam::DVec3;
use gmm_common::{context, scene_box, segment_through, Rng};

#[test]
#[ignore]
fn fit_time_for_a_million_rays() {
    let aabb = scene_box();
    let mut rng = Rng(99);
    // 48 foci (so the mixture grows towards k_max) plus 30 % uniformly random lines.
    let foci: Vec<DVec3> = (0..48)
        .map(|_| rng.in_box(aabb.min.as_dvec3() + 0.1, aabb.max.as_dvec3() - 0.1))
        .collect();
    let mut guide = GmmGuide::new(aabb, GmmConfig::default()).unwrap();
    let iterations = 6;
    for it in 0..iterations {
        let segments: Vec<_> = (0..1_000_000)
            .map(|_| {
                let y = if rng.f64() < 0.3 {
                    rng.in_box(aabb.min.as_dvec3(), aabb.max.as_dvec3())
                } else {
                    foci[(rng.next_u64() % foci.len() as u64) as usize]
                        + DVec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.01
                };
                segment_through(&mut rng, aabb, y, 1.0)
            })
            .collect();
        let stats = guide.update_with(&segments, &context(it, iterations));
        let get = |k: &str| stats.details.iter().find(|(n, _)| n == k).unwrap().1;
        println!(
            "update {it}: {:.3} s (points {:.3} s, EM {:.3} s), K = {}, rays = {}, points = {}, \
             narrowing = {}, threads = {}",
            stats.seconds,
            get("points_seconds"),
            get("fit_seconds"),
            get("k"),
            get("rays"),
            get("points"),
            get("narrowing"),
            rayon::current_num_threads()
        );
    }
}
