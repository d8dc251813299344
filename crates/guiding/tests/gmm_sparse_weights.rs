//! Issue 43's synthetic training set, as a measurement (ignored by default; run with
//! `cargo test --release -p focal-guiding --test gmm_sparse_weights -- --ignored --nocapture`, and
//! with `--features experimental` plus `MIN_EFF=R` or `POWER=β` for the experimental reweightings):
//! 5,000 light rays through two foci carry 1 % of the weight and 3 heavy rays 99 %, and the shares of
//! guided directions through each focus are printed after each update.
//! docs/experiments/2026-12-08-gmm-few-heavy-rays.md has the results.

mod gmm_common;

use focal_guiding::gmm::{GmmConfig, GmmGuide};
use focal_guiding::GuidingField;
use glam::{DVec3, Vec3};
use gmm_common::{context, scene_box, segment_through, Rng};

const A: DVec3 = DVec3::new(0.2, 0.5, 0.2);
const B: DVec3 = DVec3::new(1.0, 0.5, 0.6);

/// Shares of `n` directions sampled at `x` passing within `r` of A and of B.
fn shares(guide: &GmmGuide, x: Vec3, n: usize, r: f64, rng: &mut Rng) -> [f64; 2] {
    let mut hits = [0usize; 2];
    for _ in 0..n {
        let u = [rng.f32(), rng.f32(), rng.f32()];
        let Some(s) = guide.sample_at(x, None, u) else {
            continue;
        };
        let (o, d) = (x.as_dvec3(), s.direction.as_dvec3());
        for (j, f) in [A, B].iter().enumerate() {
            let v = *f - o;
            if (v - d * v.dot(d).max(0.0)).length() < r {
                hits[j] += 1;
            }
        }
    }
    hits.map(|h| h as f64 / n as f64)
}

#[test]
#[ignore = "a measurement (prints the shares), not a check: issue 43"]
fn few_heavy_rays_and_many_light_ones_over_two_foci() {
    for heavy_through_a in [true, false] {
        for seed in 0..3u64 {
            let aabb = scene_box();
            let mut rng = Rng(1000 + seed);
            #[allow(unused_mut)]
            let mut config = GmmConfig::default();
            #[cfg(feature = "experimental")]
            {
                if let Ok(v) = std::env::var("MIN_EFF") {
                    config.experimental.min_effective_rays = v.parse().unwrap();
                }
                if let Ok(v) = std::env::var("POWER") {
                    config.experimental.weight_power = v.parse().unwrap();
                }
            }
            let mut guide = GmmGuide::new(aabb, config).unwrap();
            let iterations = 6;
            let mut out = Vec::new();
            for it in 0..4 {
                // 5,000 light rays through the two foci carry 1 % of the weight, 3 heavy rays 99 %.
                let mut segs = Vec::new();
                for i in 0..5000 {
                    let f = if i % 2 == 0 { A } else { B };
                    let y = f + DVec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.01;
                    segs.push(segment_through(&mut rng, aabb, y, 0.01 / 5000.0));
                }
                for _ in 0..3 {
                    let y = if heavy_through_a {
                        A + DVec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.01
                    } else {
                        rng.in_box(aabb.min.as_dvec3(), aabb.max.as_dvec3())
                    };
                    segs.push(segment_through(&mut rng, aabb, y, 0.99 / 3.0));
                }
                guide.update_with(&segs, &context(it, iterations));
                let x = Vec3::new(0.6, 0.1, -0.3);
                out.push(shares(&guide, x, 20_000, 0.05, &mut rng));
            }
            println!("heavy through A: {heavy_through_a}, seed {seed}: shares [A, B] per update {out:.3?}");
        }
    }
}
