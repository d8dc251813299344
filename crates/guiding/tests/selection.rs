//! The learned guide/BSDF selection probability: the importance-reweighted second moments choose the
//! fraction a closed form says is best, per region, from the finest level with enough data.

mod gmm_common;

use focal_guiding::{
    Aabb3, GmmConfig, GmmGuide, GuidingField, SelectionConfig, SelectionGrid, SelectionLayer,
    SelectionLayerConfig, SelectionRule, SelectionSamples, SelectionSummary, TrainingSegment,
    UpdateContext,
};
use glam::Vec3;
use gmm_common::Rng;

/// Updates `grid` from the storage `samples` and gives it a fresh one for the next iteration.
fn update(grid: &mut SelectionGrid, samples: &mut SelectionSamples) -> SelectionSummary {
    let full = std::mem::replace(samples, grid.new_samples());
    let summary = grid.update(full);
    *samples = grid.new_samples();
    summary
}

fn unit_box() -> Aabb3 {
    Aabb3 {
        min: Vec3::ZERO,
        max: Vec3::ONE,
    }
}

/// A one-dimensional stand-in for a vertex's sampling problem on u ∈ [0, 1): the BSDF's density is
/// uniform, the guide's is 2 on [0, ½) and 0 above, and the integrand is `integrand(u)`. Draws `n`
/// directions at `origin` from the mixture with fraction `alpha0` and returns them as training segments
/// (contribution F/p₀).
fn segments(
    origin: Vec3,
    n: usize,
    alpha0: f64,
    integrand: impl Fn(f64) -> f64,
    rng: &mut Rng,
) -> Vec<TrainingSegment> {
    let guide_pdf = |u: f64| if u < 0.5 { 2.0 } else { 0.0 };
    (0..n)
        .filter_map(|_| {
            let u = if rng.f64() < alpha0 {
                0.5 * rng.f64()
            } else {
                rng.f64()
            };
            let (pg, pb) = (guide_pdf(u), 1.0);
            let p0 = alpha0 * pg + (1.0 - alpha0) * pb;
            let f = integrand(u);
            (f > 0.0).then(|| TrainingSegment {
                origin,
                direction: Vec3::Z,
                distance: 1.0,
                weight: (f / p0) as f32,
                pdf: p0 as f32,
                bsdf_pdf: pb as f32,
                guide_pdf: pg as f32,
                guide_fraction: alpha0 as f32,
                glossy_endpoint: false,
                glossy_origin: false,
                refracting_endpoint: false,
                emitted: 0.0,
                emitter_pdf: 0.0,
                pixel_weight: 1.0,
            })
        })
        .collect()
}

/// For the integrand F = w·2·[u < ½] + (1 − w) (a share w of it in the guide's support), the second
/// moment with fraction a is ∫F²/p_a = (w + (1 − w)/2)²/(½(2a + 1 − a))·½ + ((1 − w))²/(1 − a)·½; the
/// grid must choose the candidate that minimises it.
fn exact_best(w: f64) -> f32 {
    let m = |a: f64| {
        let inside = 2.0 * w + (1.0 - w);
        let outside = 1.0 - w;
        0.5 * inside * inside / (a + 1.0) + 0.5 * outside * outside / (1.0 - a)
    };
    let best = focal_guiding::SELECTION_CANDIDATES[1..]
        .iter()
        .copied()
        .min_by(|a, b| m(*a as f64).total_cmp(&m(*b as f64)))
        .unwrap();
    if m(0.0) <= 1.1 * m(best as f64) {
        0.0
    } else {
        best
    }
}

#[test]
fn chooses_the_fraction_with_the_least_second_moment_per_region() {
    let mut grid = SelectionGrid::new(unit_box(), SelectionConfig::default()).unwrap();
    let mut samples = grid.new_samples();
    assert!(
        grid.fraction_at(Vec3::splat(0.5), false).is_none(),
        "untrained"
    );
    let mut rng = Rng(7);
    // Four regions in the corners of the box, each its own finest cell, with the integrand all in the
    // guide's support, mostly, half and not at all.
    let cases = [
        (Vec3::new(0.05, 0.05, 0.05), 1.0),
        (Vec3::new(0.95, 0.05, 0.05), 0.8),
        (Vec3::new(0.05, 0.95, 0.05), 0.5),
        (Vec3::new(0.05, 0.05, 0.95), 0.0),
    ];
    for (origin, w) in cases {
        let f = move |u: f64| w * if u < 0.5 { 2.0 } else { 0.0 } + (1.0 - w);
        grid.record(&mut samples, &segments(origin, 40_000, 0.5, f, &mut rng));
    }
    let summary = update(&mut grid, &mut samples);
    assert_eq!(summary.coarse_share, 0.0, "every region has enough data");
    for (origin, w) in cases {
        let chosen = grid.fraction_at(origin, false).unwrap();
        eprintln!("w = {w}: chose {chosen}, closed form {}", exact_best(w));
        assert_eq!(chosen, exact_best(w), "w = {w}");
    }
    // The closed forms span the range, so the test sees distinct choices.
    assert_eq!(exact_best(1.0), 0.9);
    assert_eq!(exact_best(0.0), 0.0);
    assert!(exact_best(0.5) > 0.0 && exact_best(0.5) < 0.9);
}

/// The share rule's estimate E[c·h]/E[c], h = p_g/(p_g + p_b), is the integrand's guide-covered share
/// whatever fraction the segments were sampled with: for F = w·2·[u < ½] + (1 − w), h is 2/3 on [0, ½)
/// and 0 above, so the share is (2/3)(w + (1 − w)/2) = (1 + w)/3, then clamped.
#[test]
fn the_share_rule_chooses_the_guide_covered_share_of_the_contribution() {
    let config = SelectionConfig {
        rule: SelectionRule::ContributionShare,
        min_fraction: 0.4,
        max_fraction: 0.6,
        ..SelectionConfig::default()
    };
    for alpha0 in [0.25, 0.75] {
        let mut grid = SelectionGrid::new(unit_box(), config).unwrap();
        let mut samples = grid.new_samples();
        let mut rng = Rng(5);
        let cases = [
            (Vec3::new(0.05, 0.05, 0.05), 1.0, 0.6),
            (Vec3::new(0.95, 0.05, 0.05), 0.5, 0.5),
            (Vec3::new(0.05, 0.95, 0.05), 0.4, 1.4 / 3.0),
            (Vec3::new(0.05, 0.05, 0.95), 0.0, 0.4),
        ];
        for (origin, w, _) in cases {
            let f = move |u: f64| w * if u < 0.5 { 2.0 } else { 0.0 } + (1.0 - w);
            grid.record(&mut samples, &segments(origin, 40_000, alpha0, f, &mut rng));
        }
        update(&mut grid, &mut samples);
        for (origin, w, expected) in cases {
            let chosen = grid.fraction_at(origin, false).unwrap() as f64;
            eprintln!("alpha0 {alpha0}, w = {w}: chose {chosen:.4}, expected {expected:.4}");
            assert!((chosen - expected).abs() < 0.01, "w = {w}: {chosen}");
        }
    }
}

#[test]
fn sparse_cells_use_the_coarser_levels_choice_and_unguided_segments_teach_nothing() {
    let config = SelectionConfig::default();
    let mut grid = SelectionGrid::new(unit_box(), config).unwrap();
    let mut samples = grid.new_samples();
    let mut rng = Rng(11);
    let guided_only = |u: f64| if u < 0.5 { 2.0 } else { 0.0 };
    // Unguided segments (fraction 0) carry no guide pdf: the grid stays untrained.
    grid.record(
        &mut samples,
        &segments(Vec3::splat(0.2), 1000, 0.0, guided_only, &mut rng),
    );
    update(&mut grid, &mut samples);
    assert!(!grid.is_trained());
    // Many segments in one finest cell, a few in a neighbour of the same level-1 octant.
    grid.record(
        &mut samples,
        &segments(Vec3::splat(0.02), 5000, 0.5, guided_only, &mut rng),
    );
    grid.record(
        &mut samples,
        &segments(Vec3::splat(0.2), 10, 0.5, |_| 1.0, &mut rng),
    );
    let summary = update(&mut grid, &mut samples);
    assert!(summary.coarse_share > 0.0);
    assert_eq!(grid.fraction_at(Vec3::splat(0.02), false), Some(0.9));
    // The sparse cell's own data would say "skip", but 10 segments are too few: it inherits 0.9.
    assert_eq!(grid.fraction_at(Vec3::splat(0.2), false), Some(0.9));
    // Points outside the box clamp into its border cells; NaN lands in a valid cell.
    assert_eq!(grid.fraction_at(Vec3::splat(-5.0), false), Some(0.9));
    assert!(grid.fraction_at(Vec3::NAN, false).is_some());
}

#[test]
fn invalid_segments_are_ignored_and_the_choice_stays_finite() {
    let mut grid = SelectionGrid::new(unit_box(), SelectionConfig::default()).unwrap();
    let mut samples = grid.new_samples();
    let good = TrainingSegment {
        origin: Vec3::splat(0.5),
        direction: Vec3::Z,
        distance: 1.0,
        weight: 1.0,
        pdf: 1.0,
        bsdf_pdf: 1.0,
        guide_pdf: 1.0,
        guide_fraction: 0.5,
        glossy_endpoint: false,
        glossy_origin: false,
        refracting_endpoint: false,
        emitted: 0.0,
        emitter_pdf: 0.0,
        pixel_weight: 1.0,
    };
    let bad = [
        TrainingSegment {
            weight: f32::NAN,
            ..good
        },
        TrainingSegment {
            weight: f32::INFINITY,
            ..good
        },
        TrainingSegment { pdf: 0.0, ..good },
        TrainingSegment {
            guide_pdf: -1.0,
            ..good
        },
        TrainingSegment {
            bsdf_pdf: f32::NAN,
            ..good
        },
        TrainingSegment {
            origin: Vec3::NAN,
            ..good
        },
        // BSDF and guide pdf both 0: every candidate's moment would be infinite.
        TrainingSegment {
            bsdf_pdf: 0.0,
            guide_pdf: 0.0,
            ..good
        },
    ];
    grid.record(&mut samples, &bad);
    assert_eq!(update(&mut grid, &mut samples).segments, 0);
    assert!(!grid.is_trained());
    // A guide pdf of 0 where the BSDF's is positive: every α > 0 only dilutes the BSDF, so α = 0.
    let only_bsdf: Vec<TrainingSegment> = (0..200)
        .map(|_| TrainingSegment {
            guide_pdf: 0.0,
            pdf: 0.5,
            weight: 2.0,
            ..good
        })
        .collect();
    grid.record(&mut samples, &only_bsdf);
    update(&mut grid, &mut samples);
    assert_eq!(grid.fraction_at(Vec3::splat(0.5), false), Some(0.0));
    assert!(grid.validate().is_ok());
}

#[test]
fn gmm_guide_learns_and_saves_its_selection() {
    let aabb = Aabb3 {
        min: Vec3::splat(-1.0),
        max: Vec3::splat(1.0),
    };
    let mut rng = Rng(3);
    // Rays from around the box through a focus at the origin, guided with α = 0.5, whose whole
    // contribution lies where the guide samples: the guide learns α = 0.9 there.
    let mut batch = Vec::new();
    for _ in 0..4000 {
        let o = Vec3::new(
            rng.f64() as f32 * 1.6 - 0.8,
            rng.f64() as f32 * 1.6 - 0.8,
            -0.9,
        );
        batch.push(TrainingSegment {
            origin: o,
            direction: (-o).normalize(),
            distance: o.length() * 2.0,
            weight: 1.0,
            pdf: 2.0,
            bsdf_pdf: 0.1,
            guide_pdf: 3.9,
            guide_fraction: 0.5,
            glossy_endpoint: false,
            glossy_origin: false,
            refracting_endpoint: false,
            emitted: 0.0,
            emitter_pdf: 0.0,
            pixel_weight: 1.0,
        });
    }
    let ctx = |final_build| UpdateContext {
        iteration: 0,
        training_iterations: 4,
        final_build,
        threads: 1,
    };
    let learning = SelectionLayerConfig {
        learn: true,
        by_share: false,
        ..SelectionLayerConfig::default()
    };
    let layered = |config: SelectionLayerConfig| {
        SelectionLayer::new(GmmGuide::new(aabb, GmmConfig::default()).unwrap(), config)
    };
    let mut guide = layered(learning).unwrap();
    let x = Vec3::new(0.1, -0.2, -0.9);
    // Untrained, the guide asks for its fixed fraction.
    assert_eq!(guide.selection_probability(x, false), Some(0.75));
    // Before the final render, training keeps the fixed fraction although the grid has learned.
    guide.update_with(&batch, &ctx(false));
    assert_eq!(guide.selection_probability(x, false), Some(0.75));
    let stats = guide.update_with(&batch, &ctx(true));
    let detail = |name: &str| {
        stats
            .details
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
            .unwrap()
    };
    assert_eq!(detail("selection_segments"), 4000.0);
    assert!((detail("selection_mean") - 0.9).abs() < 1e-6);
    assert_eq!(guide.selection_probability(x, false), Some(0.9));
    let load = |bytes: &[u8], config| {
        SelectionLayer::load(bytes, config, |b| GmmGuide::load(b, GmmConfig::default()))
    };
    let loaded = load(&guide.save(), learning).unwrap();
    assert_eq!(loaded.selection_probability(x, false), Some(0.9));
    assert_eq!(loaded.save(), guide.save());
    // Loaded without learning, the guide asks for its fixed fraction.
    let unlearned = SelectionLayerConfig {
        learn: false,
        ..learning
    };
    assert_eq!(
        load(&guide.save(), unlearned)
            .unwrap()
            .selection_probability(x, false),
        Some(0.75)
    );
    // Without learning, the guide asks for its fixed fraction everywhere.
    let mut fixed = layered(SelectionLayerConfig {
        guide_fraction: Some(0.6),
        learn: false,
        ..SelectionLayerConfig::default()
    })
    .unwrap();
    fixed.update_with(&batch, &ctx(true));
    assert!(fixed.field().is_trained());
    assert_eq!(fixed.selection_probability(x, false), Some(0.6));
    // Without a fraction of its own, the renderer's (the octree's default).
    let mut renderers = layered(SelectionLayerConfig::renderers_fraction()).unwrap();
    renderers.update_with(&batch, &ctx(true));
    assert_eq!(renderers.selection_probability(x, false), None);
    for bad in [
        SelectionLayerConfig {
            guide_fraction: Some(1.0),
            ..SelectionLayerConfig::default()
        },
        SelectionLayerConfig {
            guide_fraction: None,
            learn: true,
            ..SelectionLayerConfig::default()
        },
    ] {
        assert!(layered(bad).is_err(), "{bad:?}");
    }
}
