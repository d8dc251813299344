//! Training the GMM guide: EM recovers known foci (with and without noise rays), the statistics and
//! schedule behave as specified, updates are deterministic for any thread count, snapshots round-trip
//! and reject garbage, and degenerate input never produces non-finite models.

mod gmm_common;

use std::f64::consts::PI;

use focal_guiding::gmm::em::SuffStats;
use focal_guiding::gmm::rays::{ray_points, NarrowingTable, PointSampling, TrainingRay};
use focal_guiding::gmm::{Gaussian3, GmmConfig, GmmGuide, Mixture, Sym3};
use focal_guiding::{Aabb3, GuidingField, TrainingSegment, UpdateStats, NARROWING_DECAY};
use glam::{DVec3, Vec3};
use gmm_common::{adaptive_simpson, context, exit_distance, scene_box, segment_through, Rng};

/// The three foci of the recovery tests: (weight, Gaussian), in the scene box.
fn foci() -> Vec<(f64, Gaussian3)> {
    vec![
        (
            0.5,
            Gaussian3::new(
                DVec3::new(0.2, 0.4, 0.3),
                Sym3::scaled_identity(0.02f64.powi(2)),
            )
            .unwrap(),
        ),
        (
            0.3,
            Gaussian3::new(
                DVec3::new(-0.5, 0.7, 0.6),
                Sym3::scaled_identity(0.03f64.powi(2)),
            )
            .unwrap(),
        ),
        (
            0.2,
            Gaussian3::new(
                DVec3::new(1.0, 0.2, -0.1),
                Sym3::diagonal(DVec3::new(0.04, 0.01, 0.02).powf(2.0)),
            )
            .unwrap(),
        ),
    ]
}

/// Segments through points drawn from the foci mixture, or (with probability `noise`) through uniform
/// points of the box: uniformly random lines.
fn focal_batch(rng: &mut Rng, n: usize, noise: f64) -> Vec<TrainingSegment> {
    let aabb = scene_box();
    let foci = foci();
    (0..n)
        .map(|_| {
            let y = if rng.f64() < noise {
                rng.in_box(aabb.min.as_dvec3(), aabb.max.as_dvec3())
            } else {
                let mut u = rng.f64();
                let mut j = 0;
                while j + 1 < foci.len() && u >= foci[j].0 {
                    u -= foci[j].0;
                    j += 1;
                }
                foci[j]
                    .1
                    .point(DVec3::new(rng.normal(), rng.normal(), rng.normal()))
            };
            segment_through(rng, aabb, y, 1.0)
        })
        .collect()
}

/// Segments towards glossy endpoints whose backward lines pass through `VIRTUAL` (a virtual image).
const VIRTUAL: DVec3 = DVec3::new(-0.52, 0.77, 0.64);

fn virtual_image_batch(rng: &mut Rng, n: usize) -> Vec<TrainingSegment> {
    let aabb = scene_box();
    (0..n)
        .map(|_| {
            let d = rng.sphere();
            let ahead = exit_distance(aabb, VIRTUAL, d);
            let origin = VIRTUAL + d * ((0.05 + 0.5 * rng.f64()) * ahead);
            TrainingSegment {
                origin: origin.as_vec3(),
                direction: d.as_vec3(),
                distance: (0.3 * rng.f64() * exit_distance(aabb, origin, d)) as f32,
                weight: 0.5,
                pdf: (1.0 / (4.0 * PI)) as f32,
                bsdf_pdf: (1.0 / (4.0 * PI)) as f32,
                guide_pdf: 0.0,
                guide_fraction: 0.0,
                glossy_endpoint: true,
                glossy_origin: false,
                refracting_endpoint: false,
                emitted: 0.0,
                emitter_pdf: 0.0,
                pixel_weight: 1.0,
            }
        })
        .collect()
}

fn detail(stats: &UpdateStats, key: &str) -> f64 {
    stats
        .details
        .iter()
        .find(|(k, _)| k == key)
        .unwrap_or_else(|| panic!("no detail {key}"))
        .1
}

/// Every number of both mixtures and p_div is finite, and pdf/sample behave at random queries.
fn assert_finite(guide: &GmmGuide, rng: &mut Rng) {
    assert!(guide.p_div().is_finite() && (0.0..=1.0).contains(&guide.p_div()));
    for m in [guide.converging_unit(), guide.diverging_unit()] {
        for (w, g) in m.weights().iter().zip(m.components()) {
            assert!(w.is_finite() && *w > 0.0, "weight {w}");
            assert!(g.mean().is_finite() && g.covariance().is_finite());
            assert!(g.log_normalizer().is_finite());
        }
    }
    let (sc, sd) = guide.statistics();
    assert!(sc.iter().chain(sd).all(SuffStats::is_valid));
    for _ in 0..200 {
        let x = rng.in_box(DVec3::splat(-2.0), DVec3::splat(2.0)).as_vec3();
        let d = rng.sphere().as_vec3();
        let n = Some(rng.sphere().as_vec3()).filter(|_| rng.f64() < 0.5);
        let p = guide.pdf_at(x, n, d);
        assert!(p.is_finite() && p >= 0.0, "pdf {p}");
        let u = [rng.f32(), rng.f32(), rng.f32()];
        if let Some(s) = guide.sample_at(x, n, u) {
            assert!(s.direction.is_finite() && s.pdf.is_finite() && s.pdf > 0.0);
        }
    }
}

/// Trains on `iterations` batches of the focal scene without narrowing (the schedule plans three times
/// as many iterations: with the synthetic uniform p_mix, narrowing would only sharpen the weights).
fn train_foci(noise: f64, iterations: u32, n: usize, seed: u64) -> GmmGuide {
    let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(seed);
    for i in 0..iterations {
        let stats = guide.update_with(
            &focal_batch(&mut rng, n, noise),
            &context(i, 3 * iterations),
        );
        assert_eq!(detail(&stats, "narrowing"), 0.0);
    }
    guide
}

/// Each true focus has a learned component centred on it and about its size.
///
/// Tolerance: the mean must lie within half a standard deviation of the focus (Mahalanobis distance
/// < 0.5 under the focus covariance, i.e. 5-20 mm here). Monte Carlo noise of a core fitted to ~10⁴
/// effective points is σ/100; the main bias is the asymmetric halo the box clips from the lines
/// through the focus, which pulls the core by a small fraction of its width (measured ≤ 0.15σ). Half a
/// σ is also the scale that matters for guiding: directions aimed there still cross the focus. The
/// component must be a core (largest σ at most twice the focus's), not a halo.
fn assert_foci_recovered(guide: &GmmGuide) {
    let m = guide.converging();
    for (j, (_, focus)) in foci().iter().enumerate() {
        let (fv, _) = focus.covariance().eigen();
        let best = m
            .components()
            .iter()
            .filter(|g| g.covariance().eigen().0[2].sqrt() <= 2.0 * fv[2].sqrt())
            .map(|g| focus.mahalanobis_sq(g.mean()).sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!(
            best < 0.5,
            "focus {j}: nearest core at {best:.3} σ ({} components)",
            m.len()
        );
    }
}

#[test]
fn em_recovers_three_foci() {
    let guide = train_foci(0.0, 4, 60_000, 1);
    assert_foci_recovered(&guide);
    assert!(guide.converging().len() <= GmmConfig::default().em.k_max);
    assert_eq!(guide.p_div(), 0.0);
    assert!(guide.diverging().is_empty());
}

#[test]
fn em_recovers_three_foci_among_30_percent_noise_rays() {
    let guide = train_foci(0.3, 4, 60_000, 2);
    assert_foci_recovered(&guide);
}

/// Counts, of `n` directions sampled from `x`, those passing within 3σ of each focus.
fn hits_through_foci(guide: &GmmGuide, x: Vec3, n: usize, rng: &mut Rng) -> [usize; 3] {
    let mut hits = [0usize; 3];
    for _ in 0..n {
        let u = [rng.f32(), rng.f32(), rng.f32()];
        let Some(s) = guide.sample_at(x, None, u) else {
            continue;
        };
        let (o, d) = (x.as_dvec3(), s.direction.as_dvec3());
        for (j, (_, f)) in foci().iter().enumerate() {
            let v = f.mean() - o;
            let closest = (v - d * v.dot(d).max(0.0)).length();
            if closest < 3.0 * f.covariance().eigen().0[2].sqrt() {
                hits[j] += 1;
            }
        }
    }
    hits
}

#[test]
fn narrowing_concentrates_guided_directions_on_the_foci() {
    // Four iterations of a six-iteration schedule: uniform points, so the mixture models the whole
    // line density (foci and the rays' halos), and every focus gets guided directions in proportion
    // to its weight.
    let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(3);
    for i in 0..4 {
        guide.update_with(&focal_batch(&mut rng, 60_000, 0.0), &context(i, 6));
    }
    let x = Vec3::new(0.9, 0.8, 0.8);
    let n = 20_000;
    let before = hits_through_foci(&guide, x, n, &mut rng);
    let total: usize = before.iter().sum();
    for (j, (w, _)) in foci().iter().enumerate() {
        let share = before[j] as f64 / total as f64;
        assert!(
            share > 0.5 * w,
            "focus {j}: share {share:.3} (weight {w}), {before:?}"
        );
    }
    // Iterations 4 and 5 narrow: points follow ρ along each ray, so the halo fades and the guided
    // directions concentrate on the foci (all of which stay represented).
    for i in 4..6 {
        guide.update_with(&focal_batch(&mut rng, 60_000, 0.0), &context(i, 6));
    }
    let after = hits_through_foci(&guide, x, n, &mut rng);
    let (b, a) = (
        total as f64 / n as f64,
        after.iter().sum::<usize>() as f64 / n as f64,
    );
    assert!(
        a > 0.6 && a > b + 0.2,
        "through a focus: {b:.3} before narrowing, {a:.3} after ({before:?} → {after:?})"
    );
    assert!(after.iter().all(|&h| h > n / 100), "{after:?}");
    assert_foci_recovered(&guide);
}

#[test]
fn splits_and_merges_respect_the_component_bounds() {
    // Eight well separated foci, k_max 5: splits stop at 5.
    let aabb = scene_box();
    let mut rng = Rng(5);
    let centres: Vec<DVec3> = (0..8)
        .map(|_| rng.in_box(aabb.min.as_dvec3() + 0.15, aabb.max.as_dvec3() - 0.15))
        .collect();
    let batch = |rng: &mut Rng| -> Vec<TrainingSegment> {
        (0..40_000)
            .map(|i| segment_through(rng, aabb, centres[i % 8], 1.0))
            .collect()
    };
    let mut config = GmmConfig::default();
    config.em.k_init = 2;
    config.em.k_max = 5;
    let mut guide = GmmGuide::new(aabb, config).unwrap();
    let mut splits = 0.0;
    for i in 0..4 {
        let s = guide.update_with(&batch(&mut rng), &context(i, 12));
        splits += detail(&s, "splits");
        assert!(guide.converging().len() <= 5);
    }
    assert!(splits >= 3.0, "{splits} splits");
    assert_eq!(guide.converging().len(), 5);
}

#[test]
fn near_duplicate_components_merge_but_not_below_k_min() {
    // A mixture with a near-duplicate pair (A, A') and a distinct B, trained on data from A and B:
    // A and A' merge; with k_min = 3 they may not.
    let aabb = scene_box();
    let g = |c: DVec3, s: f64| Gaussian3::new(c, Sym3::scaled_identity(s * s)).unwrap();
    let (a, b) = (DVec3::new(0.0, 0.5, 0.2), DVec3::new(0.8, 0.3, 0.6));
    let mixture = Mixture::new(
        &[0.3, 0.3, 0.4],
        vec![
            g(a, 0.05),
            g(a + DVec3::new(0.004, 0.0, 0.0), 0.05),
            g(b, 0.05),
        ],
    )
    .unwrap();
    let mut rng = Rng(19);
    let segments: Vec<TrainingSegment> = (0..30_000)
        .map(|i| {
            let c = if i % 5 < 3 { a } else { b };
            let y = c + DVec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.05;
            let d = rng.sphere();
            TrainingSegment {
                origin: (y - d * 1e-4).as_vec3(),
                direction: d.as_vec3(),
                distance: 2e-4,
                weight: 1.0,
                pdf: 0.1,
                bsdf_pdf: 0.1,
                guide_pdf: 0.0,
                guide_fraction: 0.0,
                glossy_endpoint: false,
                glossy_origin: false,
                refracting_endpoint: false,
                emitted: 0.0,
                emitter_pdf: 0.0,
                pixel_weight: 1.0,
            }
        })
        .collect();
    for (k_min, expect_merge) in [(1, true), (3, false)] {
        let mut config = GmmConfig::default();
        config.em.k_min = k_min;
        let mut guide =
            GmmGuide::from_mixtures(aabb, config, &mixture, &Mixture::empty(), 0.0).unwrap();
        let s = guide.update_with(&segments, &context(1, 6));
        assert_eq!(detail(&s, "merges") > 0.0, expect_merge, "k_min {k_min}");
        assert!(guide.converging().len() >= k_min);
        if expect_merge {
            let near_a = guide
                .converging()
                .components()
                .iter()
                .filter(|c| c.mean().distance(a) < 0.02)
                .count();
            assert_eq!(near_a, 1);
        }
    }
}

#[test]
fn the_diverging_mixture_learns_a_virtual_image_and_p_div_its_mass_share() {
    let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(6);
    for i in 0..3 {
        let mut batch = focal_batch(&mut rng, 30_000, 0.0);
        batch.extend(virtual_image_batch(&mut rng, 10_000));
        let s = guide.update_with(&batch, &context(i, 9));
        let (wc, wd) = (detail(&s, "w_conv"), detail(&s, "w_div"));
        assert_eq!(guide.p_div(), wd / (wc + wd));
        assert_eq!(detail(&s, "p_div"), guide.p_div());
    }
    assert!(
        guide.p_div() > 0.05 && guide.p_div() < 0.95,
        "p_div {}",
        guide.p_div()
    );
    let div = guide.diverging();
    let nearest = div
        .components()
        .iter()
        .map(|g| g.mean().distance(VIRTUAL))
        .fold(f64::INFINITY, f64::min);
    assert!(
        nearest < 0.02,
        "no diverging component at the virtual image ({nearest})"
    );
}

#[test]
fn lines_through_refracting_glass_are_segments_unless_told_otherwise() {
    // The virtual-image batch with refracting endpoints: by default each is its finite segment
    // (converging only, p_div 0); with `extend_through_refraction` the backward lines meet at the
    // virtual image as for a mirror.
    let glass = |rng: &mut Rng| {
        let mut b = virtual_image_batch(rng, 10_000);
        b.iter_mut().for_each(|s| s.refracting_endpoint = true);
        b
    };
    let mut plain = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let s = plain.update_with(&glass(&mut Rng(6)), &context(0, 9));
    assert_eq!(detail(&s, "rays_div"), 0.0);
    assert_eq!(plain.p_div(), 0.0);
    let mut config = GmmConfig::default();
    config.points.extend_through_refraction = true;
    let mut extended = GmmGuide::new(scene_box(), config).unwrap();
    let s = extended.update_with(&glass(&mut Rng(6)), &context(0, 9));
    assert_eq!(detail(&s, "rays_div"), 10_000.0);
    assert!(extended.p_div() > 0.05, "p_div {}", extended.p_div());
}

#[test]
fn a_mixture_with_a_negligible_share_of_the_data_is_dropped() {
    // Virtual-image rays carrying 1e-5 of the weight: fitting them would cost a second mixture's pdf at
    // every vertex for nothing, so the diverging mixture stays empty and p_div exactly 0.
    let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(8);
    for i in 0..3 {
        let mut batch = focal_batch(&mut rng, 20_000, 0.0);
        batch.extend(
            virtual_image_batch(&mut rng, 2_000)
                .into_iter()
                .map(|mut s| {
                    s.weight = 1e-6;
                    s
                }),
        );
        let s = guide.update_with(&batch, &context(i, 9));
        assert_eq!(detail(&s, "dropped_div"), 1.0);
        assert_eq!(detail(&s, "dropped_conv"), 0.0);
    }
    assert!(guide.diverging().is_empty());
    assert_eq!(guide.p_div(), 0.0);
    assert!(!guide.converging().is_empty());
}

#[test]
fn stepwise_statistics_decay_and_the_schedule_switches_to_narrowing() {
    let mut guide = GmmGuide::new(scene_box(), GmmConfig::default()).unwrap();
    let mut rng = Rng(7);
    let first = guide.update_with(&focal_batch(&mut rng, 20_000, 0.1), &context(0, 6));
    assert_eq!(detail(&first, "decay"), 0.5);
    // An update without data decays the statistics and, since the prior scales with the data, leaves
    // the mixture exactly as it was.
    let before = guide.converging_unit().clone();
    let w0 = detail(&first, "w_conv");
    let empty = guide.update_with(&[], &context(1, 6));
    assert_eq!(detail(&empty, "w_conv"), 0.5 * w0);
    assert_eq!(guide.converging_unit(), &before);
    assert_eq!(detail(&empty, "rays"), 0.0);
    // From ⌊2N/3⌋ = 4 on: narrowing and decay 0.25.
    for i in 2..6 {
        let s = guide.update_with(&focal_batch(&mut rng, 20_000, 0.1), &context(i, 6));
        let narrowing = i >= 4;
        assert_eq!(
            detail(&s, "narrowing"),
            narrowing as u8 as f64,
            "iteration {i}"
        );
        assert_eq!(
            detail(&s, "decay"),
            if narrowing { NARROWING_DECAY } else { 0.5 }
        );
        for key in ["k", "rays", "points", "em_iterations", "fit_seconds"] {
            assert!(detail(&s, key) > 0.0, "{key}");
        }
        assert_eq!(s.model_size as f64, detail(&s, "k"));
        assert_eq!(s.segments, 20_000);
    }
    assert_foci_recovered(&guide);
}

#[test]
fn narrowing_starts_at_the_configured_share_of_the_iterations() {
    // (share, N, first narrowing iteration): the default 2/3 of 15 is 10 despite 2/3's rounding.
    for (share, n, start) in [
        (2.0 / 3.0, 15, 10),
        (2.0 / 3.0, 6, 4),
        (0.5, 6, 3),
        (0.25, 4, 1),
    ] {
        let mut config = GmmConfig::default();
        config.schedule.narrowing_start = share;
        config.em.k_init = 2;
        config.points.max = 4096;
        let mut guide = GmmGuide::new(scene_box(), config).unwrap();
        let mut rng = Rng(11);
        for i in 0..n {
            let s = guide.update_with(&focal_batch(&mut rng, 500, 0.1), &context(i, n));
            assert_eq!(
                detail(&s, "narrowing"),
                (i >= start) as u8 as f64,
                "share {share}, N {n}, iteration {i}"
            );
        }
    }
    let mut bad = GmmConfig::default();
    bad.schedule.narrowing_start = 1.5;
    assert!(GmmGuide::new(scene_box(), bad).is_err());
}

#[test]
fn recording_does_not_change_the_model_until_update() {
    let mut guide = train_foci(0.0, 2, 20_000, 8);
    let mut rng = Rng(9);
    let queries: Vec<(Vec3, Vec3, [f32; 3])> = (0..300)
        .map(|_| {
            (
                rng.in_box(DVec3::splat(-1.0), DVec3::splat(1.0)).as_vec3(),
                rng.sphere().as_vec3(),
                [rng.f32(), rng.f32(), rng.f32()],
            )
        })
        .collect();
    let snapshot = |g: &GmmGuide| -> Vec<_> {
        queries
            .iter()
            .map(|(x, d, u)| {
                (
                    g.pdf_at(*x, None, *d).to_bits(),
                    g.sample_at(*x, Some(*d), *u),
                )
            })
            .collect()
    };
    let before = snapshot(&guide);
    let mut samples = guide.new_samples();
    guide.add_samples(&mut samples, &focal_batch(&mut rng, 5_000, 0.5));
    guide.add_samples(&mut samples, &virtual_image_batch(&mut rng, 5_000));
    assert_eq!(snapshot(&guide), before);
    assert_eq!(guide.stored_rays(&mut samples), (10_000, 5_000));
    assert_eq!(samples.segments(), 10_000);
    // The storage belongs to the model it was made for.
    guide.update(samples, &context(2, 6));
    let stale = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut old = guide.new_samples();
        guide.update_with(&[], &context(3, 6));
        guide.add_samples(&mut old, &focal_batch(&mut Rng(1), 10, 0.0));
    }));
    assert!(stale.is_err(), "a storage of an earlier model was accepted");
}

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
