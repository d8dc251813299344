//! Training the GMM guide: EM recovers known foci (with and without noise rays), and the statistics
//! and schedule behave as specified.

mod gmm_common;

use focal_guiding::gmm::{Gaussian3, GmmConfig, GmmGuide, Mixture, Sym3};
use focal_guiding::{GuidingField, TrainingSegment, NARROWING_DECAY};
use glam::{DVec3, Vec3};
use gmm_common::training::*;
use gmm_common::{context, scene_box, segment_through, Rng};

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
