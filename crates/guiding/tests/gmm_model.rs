//! The GMM guide's model and buffers: updates are deterministic for any thread count, snapshots
//! round-trip and reject garbage, degenerate input never produces non-finite models, and the ray
//! buffers, points and statistics keep their weights.

mod gmm_common;

use focal_guiding::gmm::em::SuffStats;
use focal_guiding::gmm::rays::{ray_points, NarrowingTable, PointSampling, TrainingRay};
use focal_guiding::gmm::{GmmConfig, GmmGuide, Mixture, Sym3};
use focal_guiding::{Aabb3, GuidingField, TrainingSegment};
use glam::DVec3;
use gmm_common::training::*;
use gmm_common::{adaptive_simpson, context, scene_box, Rng};

#[test]
fn updates_are_deterministic_for_any_thread_count() {
    let mut rng = Rng(10);
    let batches: Vec<Vec<TrainingSegment>> = (0..3)
        .map(|_| {
            let mut b = focal_batch(&mut rng, 15_000, 0.3);
            b.extend(virtual_image_batch(&mut rng, 4_000));
            b
        })
        .collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
            // Three iterations of a three-iteration schedule: the last one narrows.
            for (i, batch) in batches.iter().enumerate() {
                let (a, b) = batch.split_at(7_000);
                let mut samples = guide.new_samples();
                guide.add_samples(&mut samples, a);
                guide.add_samples(&mut samples, b);
                guide.update(samples, &context(i as u32, 3));
            }
            guide.save()
        })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

#[test]
fn save_load_round_trip_is_bit_identical() {
    let mut guide = train_foci(0.2, 2, 20_000, 11);
    let mut rng = Rng(12);
    guide.update_with(&virtual_image_batch(&mut rng, 5_000), &context(2, 6));
    let bytes = guide.save();
    let loaded = GmmGuide::load(&bytes, GmmConfig::default()).unwrap();
    assert_eq!(loaded.save(), bytes);
    assert_eq!(loaded.p_div(), guide.p_div());
    assert_eq!(loaded.updates(), guide.updates());
    for _ in 0..3000 {
        let x = rng.in_box(DVec3::splat(-1.5), DVec3::splat(1.5)).as_vec3();
        let d = rng.sphere().as_vec3();
        let n = Some(rng.sphere().as_vec3()).filter(|_| rng.f64() < 0.5);
        assert_eq!(
            loaded.pdf_at(x, n, d).to_bits(),
            guide.pdf_at(x, n, d).to_bits()
        );
        let u = [rng.f32(), rng.f32(), rng.f32()];
        assert_eq!(loaded.sample_at(x, n, u), guide.sample_at(x, n, u));
    }
    // Training continues identically from the snapshot.
    let batch = focal_batch(&mut rng, 10_000, 0.2);
    let mut a = guide.clone();
    let mut b = loaded;
    a.update_with(&batch, &context(3, 6));
    b.update_with(&batch, &context(3, 6));
    assert_eq!(a.save(), b.save());
}

#[test]
fn load_rejects_garbage_without_panicking() {
    let guide = train_foci(0.0, 1, 10_000, 13);
    let bytes = guide.save();
    for len in 0..bytes.len() {
        assert!(
            GmmGuide::load(&bytes[..len], GmmConfig::default()).is_err(),
            "prefix of {len} bytes"
        );
    }
    assert!(GmmGuide::load(b"not a snapshot at all", GmmConfig::default()).is_err());
    let mut wrong = bytes.clone();
    wrong[0] ^= 1; // magic
    assert!(GmmGuide::load(&wrong, GmmConfig::default()).is_err());
    let mut wrong = bytes.clone();
    wrong[8] ^= 0x7f; // version
    assert!(GmmGuide::load(&wrong, GmmConfig::default()).is_err());
    // Random corruption: an error or a valid model, never a panic or a non-finite model.
    let mut rng = Rng(14);
    for _ in 0..2000 {
        let mut c = bytes.clone();
        for _ in 0..1 + rng.next_u64() % 4 {
            let at = (rng.next_u64() % c.len() as u64) as usize;
            c[at] ^= 1 << (rng.next_u64() % 8);
        }
        if let Ok(g) = GmmGuide::load(&c, GmmConfig::default()) {
            assert_finite(&g, &mut rng);
        }
    }
    let random: Vec<u8> = (0..4096).map(|_| rng.next_u64() as u8).collect();
    assert!(GmmGuide::load(&random, GmmConfig::default()).is_err());
}

#[test]
fn degenerate_inputs_give_finite_models() {
    let aabb = scene_box();
    let mut rng = Rng(15);
    let seg = |o: DVec3, d: DVec3, distance: f32, weight: f32, glossy: bool| TrainingSegment {
        origin: o.as_vec3(),
        direction: d.as_vec3(),
        distance,
        weight,
        pdf: 0.3,
        bsdf_pdf: 0.3,
        guide_pdf: 0.0,
        guide_fraction: 0.0,
        glossy_endpoint: glossy,
        glossy_origin: false,
        refracting_endpoint: false,
        emitted: 0.0,
        emitter_pdf: 0.0,
        pixel_weight: 1.0,
    };
    let cases: Vec<(&str, Vec<TrainingSegment>, bool)> = vec![
        (
            "all rays parallel",
            (0..5000)
                .map(|i| {
                    let o = DVec3::new(
                        -0.9,
                        0.05 + 0.9 * (i % 70) as f64 / 70.0,
                        -0.4 + 1.3 * (i / 70) as f64 / 72.0,
                    );
                    seg(o, DVec3::X, 2.0, 1.0, i % 2 == 0)
                })
                .collect(),
            true,
        ),
        (
            "one ray",
            vec![seg(
                DVec3::new(0.0, 0.5, 0.2),
                DVec3::new(0.6, 0.0, 0.8),
                0.7,
                2.0,
                false,
            )],
            true,
        ),
        (
            "rays through one point",
            (0..3000)
                .map(|_| {
                    let d = rng.sphere();
                    seg(DVec3::new(0.3, 0.3, 0.3) - d * 1e-7, d, 2e-7, 1.0, false)
                })
                .collect(),
            true,
        ),
        (
            "all weights zero",
            (0..100)
                .map(|_| seg(DVec3::new(0.0, 0.5, 0.0), rng.sphere(), 0.5, 0.0, false))
                .collect(),
            false,
        ),
        (
            "zero-length rays",
            (0..100)
                .map(|_| seg(DVec3::new(0.0, 0.5, 0.0), rng.sphere(), 0.0, 1.0, false))
                .collect(),
            false,
        ),
        (
            "outside the box",
            (0..100)
                .map(|_| seg(DVec3::new(5.0, 5.0, 5.0), DVec3::X, 1.0, 1.0, false))
                .collect(),
            false,
        ),
        (
            "invalid numbers",
            vec![
                seg(DVec3::new(0.0, 0.5, 0.0), DVec3::X, 1.0, f32::NAN, false),
                seg(
                    DVec3::new(0.0, 0.5, 0.0),
                    DVec3::X,
                    1.0,
                    f32::INFINITY,
                    false,
                ),
                seg(DVec3::new(0.0, 0.5, 0.0), DVec3::X, 1.0, -1.0, false),
                seg(DVec3::new(0.0, 0.5, 0.0), DVec3::ZERO, 1.0, 1.0, false),
                seg(
                    DVec3::new(0.0, 0.5, 0.0),
                    DVec3::splat(f64::NAN),
                    1.0,
                    1.0,
                    false,
                ),
                seg(DVec3::splat(f64::NAN), DVec3::X, 1.0, 1.0, false),
                seg(DVec3::new(0.0, 0.5, 0.0), DVec3::X, f32::NAN, 1.0, false),
                seg(DVec3::new(0.0, 0.5, 0.0), DVec3::X, -1.0, 1.0, false),
                TrainingSegment {
                    pdf: f32::NAN,
                    bsdf_pdf: f32::NAN,
                    guide_pdf: 0.0,
                    guide_fraction: 0.0,
                    ..seg(DVec3::new(0.0, 0.5, 0.0), DVec3::X, 1.0, 1.0, false)
                },
                TrainingSegment {
                    pdf: 0.0,
                    bsdf_pdf: 0.0,
                    guide_pdf: 0.0,
                    guide_fraction: 0.0,
                    ..seg(DVec3::new(0.0, 0.5, 0.0), DVec3::X, 1.0, 1.0, false)
                },
            ],
            false,
        ),
    ];
    for (name, segments, trains) in cases {
        let mut guide = GmmGuide::new(aabb, GmmConfig::default()).unwrap();
        for i in 0..4 {
            let s = guide.update_with(&segments, &context(i, 6));
            assert!(
                s.details.iter().all(|(_, v)| v.is_finite()),
                "{name}: {:?}",
                s.details
            );
            if name == "invalid numbers" {
                assert_eq!(detail(&s, "segments_dropped"), 10.0, "{name}");
            }
        }
        assert_eq!(guide.is_trained(), trains, "{name}");
        assert_finite(&guide, &mut rng);
        let loaded = GmmGuide::load(&guide.save(), GmmConfig::default()).unwrap();
        assert_eq!(loaded.save(), guide.save(), "{name}");
    }
}

#[test]
fn ray_buffers_are_thinned_at_the_cap_with_their_weight_kept() {
    let mut config = GmmConfig::default();
    config.points.max_rays = 10_000;
    let mut capped = GmmGuide::new(scene_box(), config).unwrap();
    let mut full = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(16);
    let batch = focal_batch(&mut rng, 35_000, 0.3);
    let (mut capped_samples, mut full_samples) = (capped.new_samples(), full.new_samples());
    for chunk in batch.chunks(5_000) {
        capped.add_samples(&mut capped_samples, chunk);
        full.add_samples(&mut full_samples, chunk);
    }
    assert!(capped.stored_rays(&mut capped_samples).0 <= 10_000);
    let a = capped.update(capped_samples, &context(0, 6));
    let b = full.update(full_samples, &context(0, 6));
    assert!(detail(&a, "thinning_rounds") >= 2.0);
    assert_eq!(detail(&b, "thinning_rounds"), 0.0);
    // Every other ray with doubled weight: the same total within sampling noise.
    let (wa, wb) = (detail(&a, "w_conv"), detail(&b, "w_conv"));
    assert!((wa / wb - 1.0).abs() < 0.05, "{wa} vs {wb}");
    assert_finite(&capped, &mut rng);
}

#[test]
fn statistics_combine_subtract_and_decay_consistently() {
    let mut rng = Rng(17);
    let pts: Vec<(DVec3, f64)> = (0..200)
        .map(|_| {
            (
                rng.in_box(DVec3::splat(100.0), DVec3::splat(101.0)),
                0.1 + rng.f64(),
            )
        })
        .collect();
    let stats = |p: &[(DVec3, f64)]| {
        let w: f64 = p.iter().map(|(_, w)| w).sum();
        let mean = p.iter().map(|(y, w)| *y * *w).sum::<DVec3>() / w;
        let scatter = p
            .iter()
            .fold(Sym3::ZERO, |s, (y, w)| s + Sym3::outer(*y - mean) * *w);
        SuffStats {
            weight: w,
            mean,
            scatter,
        }
    };
    let (a, b) = pts.split_at(70);
    let all = stats(&pts);
    let combined = stats(a).combine(&stats(b));
    let close = |x: &SuffStats, y: &SuffStats| {
        (x.weight - y.weight).abs() < 1e-12 * y.weight
            && x.mean.distance(y.mean) < 1e-12
            && (0..6).all(|i| (x.scatter.0[i] - y.scatter.0[i]).abs() < 1e-11)
    };
    assert!(close(&combined, &all));
    let rest = all.subtract(&stats(b)).unwrap();
    assert!(close(&rest, &stats(a)));
    assert_eq!(all.scaled(0.5).combine(&all.scaled(0.5)).weight, all.weight);
    // Removing more than the data holds is refused.
    assert!(stats(b).subtract(&all).is_none());
}

#[test]
fn ray_points_carry_the_specified_weights() {
    let ray = TrainingRay {
        origin: [-0.4, 0.1, 0.2],
        direction: DVec3::new(0.8, 0.1, -0.3).normalize().as_vec3().to_array(),
        t0: 0.1,
        t1: 0.9,
        weight: 2.5,
        pdf: 0.7,
    };
    // Uniform: n stratified points of weight c·length/n.
    let mut out = Vec::new();
    ray_points(&ray, 42, 4, PointSampling::Uniform, 1.0, &mut out);
    assert_eq!(out.len(), 4);
    for (j, p) in out.iter().enumerate() {
        assert!((p.weight as f64 - 2.5 * 0.8 / 4.0).abs() < 1e-6);
        let t = (p.pos() - DVec3::from_array(ray.origin.map(|v| v as f64))).length();
        assert!(t >= 0.1 + 0.2 * j as f64 - 1e-6 && t <= 0.1 + 0.2 * (j + 1) as f64 + 1e-6);
    }
    // Narrowing: the mean total weight is c·P_sel·∫ρ(x + tω) t² dt / p_mix (the RAY_WEIGHTED target).
    let mut rng = Rng(18);
    let mixture = gmm_common::random_mixture(&mut rng, 4, DVec3::new(0.0, 0.15, 0.1), 0.05, 0.3);
    let table = NarrowingTable::new(&mixture, 0.8);
    let o = DVec3::from_array(ray.origin.map(|v| v as f64));
    let w = DVec3::from_array(ray.direction.map(|v| v as f64));
    let target = adaptive_simpson(
        &|t: f64| mixture.density(o + w * t) * t * t,
        0.1,
        0.9,
        1e-12,
        64,
    ) * 2.5
        * 0.8
        / 0.7;
    let trials = 20_000;
    let mut sum = 0.0;
    let mut sum2 = 0.0;
    for key in 0..trials {
        out.clear();
        ray_points(
            &ray,
            key,
            2,
            PointSampling::Narrowing(&table),
            1.0,
            &mut out,
        );
        let total: f64 = out.iter().map(|p| p.weight as f64).sum();
        sum += total;
        sum2 += total * total;
    }
    let mean = sum / trials as f64;
    let err = ((sum2 / trials as f64 - mean * mean).max(0.0) / trials as f64).sqrt();
    assert!(
        (mean - target).abs() < 5.0 * err + 1e-6 * target,
        "narrowing weight {mean} ± {err}, target {target}"
    );
    let _ = Mixture::empty();
    let _: Aabb3 = scene_box();
}

#[test]
fn a_stride_subset_of_the_rays_keeps_the_total_mass_in_expectation() {
    use focal_guiding::gmm::rays::{generate_points, PointSampling};
    use focal_guiding::gmm::TrainingRay;
    // 10 000 rays of varied weight and length, at most 2 000 points of 2 per ray: every fifth ray, with
    // five times the weight.
    let rays: Vec<TrainingRay> = (0..10_000)
        .map(|i| TrainingRay {
            origin: [0.0, 0.0, i as f32 * 1e-4],
            direction: [1.0, 0.0, 0.0],
            t0: 0.0,
            t1: 0.5 + (i % 7) as f32 * 0.1,
            weight: 1.0 + (i % 11) as f32,
            pdf: 1.0,
        })
        .collect();
    let mass: f64 = rays
        .iter()
        .map(|r| r.weight as f64 * (r.t1 - r.t0) as f64)
        .sum();
    let points = generate_points(&rays, 2, 2_000, PointSampling::Uniform, 99);
    assert_eq!(points.len(), 2_000);
    let total: f64 = points.iter().map(|p| p.weight as f64).sum();
    assert!((total / mass - 1.0).abs() < 0.02, "{total} vs {mass}");
    // Few rays: every ray is used as is.
    let few = generate_points(&rays[..500], 2, 2_000, PointSampling::Uniform, 99);
    assert_eq!(few.len(), 1_000);
    let few_total: f64 = few.iter().map(|p| p.weight as f64).sum();
    let few_mass: f64 = rays[..500]
        .iter()
        .map(|r| r.weight as f64 * (r.t1 - r.t0) as f64)
        .sum();
    assert!((few_total / few_mass - 1.0).abs() < 1e-5);
}
