//! Tests of the focal-guiding octree against the properties in `docs/design/octree.md` §9.

use std::f64::consts::PI;

use focal_guiding::octree::{
    lattice_plane, substitute_zero_components, FocalOctreeGuide, FocalTree, OctreeGuideConfig,
    SplatStrategy, TreeConfig,
};
use focal_guiding::{Aabb3, GuidingField, TrainingSegment, UpdateContext};
use glam::{DVec3, UVec3, Vec3};

/// A small deterministic generator (SplitMix64) so the tests need no extra dependency.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }
    fn sphere(&mut self) -> DVec3 {
        let z = 1.0 - 2.0 * self.f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * self.f64();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
    fn in_box(&mut self, lo: DVec3, hi: DVec3) -> DVec3 {
        lo + (hi - lo) * DVec3::new(self.f64(), self.f64(), self.f64())
    }
}

/// An anisotropic scene box, so cells are not cubes.
fn scene_box() -> Aabb3 {
    Aabb3 {
        min: Vec3::new(-1.0, 0.0, -0.5),
        max: Vec3::new(1.5, 1.0, 1.0),
    }
}

const FOCUS: DVec3 = DVec3::new(0.23, 0.41, 0.17);
const VIRTUAL_FOCUS: DVec3 = DVec3::new(-0.52, 0.77, 0.64);

/// Exit distance from the box along a unit direction (origin inside).
fn exit(aabb: Aabb3, o: DVec3, d: DVec3) -> f64 {
    let d = substitute_zero_components(d);
    let t0 = (aabb.min.as_dvec3() - o) / d;
    let t1 = (aabb.max.as_dvec3() - o) / d;
    t0.max(t1).min_element()
}

/// Segments through `FOCUS` in uniformly random directions (weight 1, uniform pdf, diffuse endpoints).
fn focal_segments(rng: &mut Rng, n: usize) -> Vec<TrainingSegment> {
    let aabb = scene_box();
    (0..n)
        .map(|_| {
            let d = rng.sphere();
            let back = rng.f64() * exit(aabb, FOCUS, -d);
            let forward = rng.f64() * exit(aabb, FOCUS, d);
            TrainingSegment {
                origin: (FOCUS - back * d).as_vec3(),
                direction: d.as_vec3(),
                distance: (back + forward) as f32,
                weight: 1.0,
                pdf: (1.0 / (4.0 * PI)) as f32,
                bsdf_pdf: (1.0 / (4.0 * PI)) as f32,
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
        .collect()
}

/// Segments towards glossy endpoints whose backward lines pass through `VIRTUAL_FOCUS` (a virtual image).
fn virtual_image_segments(rng: &mut Rng, n: usize) -> Vec<TrainingSegment> {
    let aabb = scene_box();
    (0..n)
        .map(|_| {
            let d = rng.sphere();
            let ahead = exit(aabb, VIRTUAL_FOCUS, d);
            let origin = VIRTUAL_FOCUS + (0.05 + 0.5 * rng.f64()) * ahead * d;
            TrainingSegment {
                origin: origin.as_vec3(),
                direction: d.as_vec3(),
                distance: (0.3 * rng.f64() * exit(aabb, origin, d)) as f32,
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

fn context(iteration: u32, training_iterations: u32, threads: usize) -> UpdateContext {
    UpdateContext {
        iteration,
        training_iterations,
        final_build: iteration + 1 == training_iterations,
        threads,
    }
}

/// A guide trained for `iterations` of `n` focal plus `n / 4` virtual-image segments each, in RAY mode
/// (the schedule plans three times as many iterations, so narrowing and pruning never start; with the
/// synthetic uniform p_mix, narrowing would starve the diverging tree).
fn trained_guide(iterations: u32, n: usize, seed: u64) -> FocalOctreeGuide {
    let mut guide = FocalOctreeGuide::new(scene_box(), OctreeGuideConfig::default()).unwrap();
    let mut rng = Rng(seed);
    for i in 0..iterations {
        let mut segments = focal_segments(&mut rng, n);
        segments.extend(virtual_image_segments(&mut rng, n / 4));
        guide.update_with(&segments, &context(i, 3 * iterations, 1));
    }
    guide
}

/// Σ ρ_L V_L over the leaves.
fn total_probability(tree: &FocalTree) -> f64 {
    tree.leaves()
        .iter()
        .map(|l| l.density as f64 * tree.slot_volume(l.depth))
        .sum()
}

/// World bounds of a leaf cell, computed plane by plane from the lattice.
fn leaf_bounds(tree: &FocalTree, depth: u32, cell: UVec3) -> (DVec3, DVec3) {
    let aabb = tree.aabb();
    let (lo, ext) = (
        aabb.min.as_dvec3(),
        aabb.max.as_dvec3() - aabb.min.as_dvec3(),
    );
    let scale = 0.5f64.powi(depth as i32 + 1);
    let plane = |axis: usize, k: u32| lattice_plane(lo[axis], ext[axis], k, scale);
    (
        DVec3::new(plane(0, cell.x), plane(1, cell.y), plane(2, cell.z)),
        DVec3::new(
            plane(0, cell.x + 1),
            plane(1, cell.y + 1),
            plane(2, cell.z + 1),
        ),
    )
}

#[test]
fn clear_gives_uniform_16_cubed_grid() {
    let tree = FocalTree::new(scene_box(), TreeConfig::default());
    assert_eq!(tree.nodes().len(), 585);
    let leaves = tree.leaves();
    assert_eq!(leaves.len(), 4096);
    assert!(leaves
        .iter()
        .all(|l| l.depth == 3 && l.density == leaves[0].density));
    let volume = 2.5 * 1.0 * 1.5;
    assert!((leaves[0].density as f64 * volume - 1.0).abs() < 1e-6);
    assert!((total_probability(&tree) - 1.0).abs() < 1e-6);
}

#[test]
fn traversal_matches_brute_force_slab_tests() {
    let guide = trained_guide(4, 4000, 7);
    let tree = guide.converging();
    let leaves = tree.leaves();
    assert!(
        tree.max_leaf_depth() > 5,
        "the test tree should be adaptive"
    );
    let aabb = tree.aabb();
    let (lo, hi) = (aabb.min.as_dvec3(), aabb.max.as_dvec3());
    let mut rng = Rng(11);
    let mut total_hits = 0usize;
    for ray in 0..400 {
        let mut o = match ray % 4 {
            0 => rng.in_box(lo, hi),
            1 => rng.in_box(lo - 1.0, hi + 1.0),
            2 => FOCUS,
            _ => {
                // On the boundary or on an interior lattice plane.
                let mut o = rng.in_box(lo, hi);
                let axis = ray / 4 % 3;
                o[axis] = [
                    lo[axis],
                    hi[axis],
                    lattice_plane(lo[axis], hi[axis] - lo[axis], 1, 0.5),
                ][ray / 12 % 3];
                o
            }
        };
        if ray % 7 == 0 {
            o = o.round();
        }
        let mut d = rng.sphere();
        match ray % 5 {
            0 => d.x = 0.0,
            1 => {
                d.y = 0.0;
                d.z = 0.0
            }
            _ => {}
        }
        let d = d.normalize();
        let t_max = if ray % 3 == 0 {
            0.1 + 2.0 * rng.f64()
        } else {
            f64::INFINITY
        };

        let mut traversed = Vec::new();
        tree.for_each_leaf_on_ray(o, d, t_max, |hit| {
            traversed.push((hit.slot, hit.t_in, hit.t_out))
        });
        traversed.sort_by_key(|h| h.0);

        let inv = substitute_zero_components(d).recip();
        let mut brute = Vec::new();
        for leaf in &leaves {
            let (bmin, bmax) = leaf_bounds(tree, leaf.depth, leaf.cell);
            let t0 = (bmin - o) * inv;
            let t1 = (bmax - o) * inv;
            let t_in = t0.min(t1).max_element().max(0.0);
            let t_out = t0.max(t1).min_element().min(t_max);
            if t_in < t_out {
                brute.push((leaf.slot, t_in, t_out));
            }
        }
        brute.sort_by_key(|h| h.0);
        assert_eq!(
            traversed, brute,
            "ray {ray}: o = {o}, d = {d}, t_max = {t_max}"
        );

        // The intervals partition the ray's part inside the box.
        let inv_root = inv;
        let (r0, r1) = ((lo - o) * inv_root, (hi - o) * inv_root);
        let root_in = r0.min(r1).max_element().max(0.0);
        let root_out = r0.max(r1).min_element().min(t_max);
        let covered: f64 = traversed.iter().map(|h| h.2 - h.1).sum();
        let expected = (root_out - root_in).max(0.0);
        assert!(
            (covered - expected).abs() <= 1e-9 * (1.0 + expected),
            "ray {ray}: {covered} vs {expected}"
        );
        total_hits += traversed.len();
    }
    assert!(
        total_hits > 2000,
        "rays should cross many leaves, got {total_hits}"
    );
}

/// Mixture importance sampling estimate of ∫ p(ω) dω with 0.5 uniform + 0.5 the guide's own sampler.
/// Each term is p/(0.5/(4π) + 0.5p) ∈ [0, 2], so its variance is at most 1 and the standard error of the
/// mean of 1e5 terms at most 0.0032; 0.016 is a 5σ bound that needs no empirical variance.
fn sphere_integral(guide: &FocalOctreeGuide, x: Vec3, rng: &mut Rng) -> f64 {
    let n = 100_000;
    let uniform = 1.0 / (4.0 * PI);
    let mut sum = 0.0;
    for _ in 0..n {
        let d = if rng.f64() < 0.5 {
            rng.sphere().as_vec3()
        } else {
            let s = guide
                .sample_at(x, None, [rng.f32(), rng.f32(), rng.f32()])
                .expect("the guide samples");
            assert_eq!(
                s.pdf,
                guide.pdf_at(x, None, s.direction),
                "sample pdf must equal pdf()"
            );
            s.direction
        };
        let p = guide.pdf_at(x, None, d) as f64;
        sum += p / (0.5 * uniform + 0.5 * p);
    }
    sum / n as f64
}

#[test]
fn pdf_integrates_to_one_over_the_sphere() {
    let guide = trained_guide(6, 8000, 3);
    assert!(
        guide.p_div() > 0.01 && guide.p_div() < 0.99,
        "both trees should matter: {}",
        guide.p_div()
    );
    let mut rng = Rng(5);
    for x in [
        Vec3::new(0.9, 0.2, 0.6),
        Vec3::new(-3.0, 2.5, 4.0),
        FOCUS.as_vec3(),
        VIRTUAL_FOCUS.as_vec3(),
    ] {
        let integral = sphere_integral(&guide, x, &mut rng);
        assert!((integral - 1.0).abs() < 0.016, "∫pdf from {x} = {integral}");
    }
}

/// Pearson chi-square with bins of expectation < 5 pooled; returns the p-value.
fn chi_square_p_value(observed: &[f64], expected: &[f64]) -> f64 {
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut stat, mut bins) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for i in order {
        if expected[i] <= 0.0 {
            assert_eq!(
                observed[i], 0.0,
                "samples fell into a bin of zero probability"
            );
            continue;
        }
        if expected[i] < 5.0 {
            pool_o += observed[i];
            pool_e += expected[i];
            if pool_e >= 5.0 {
                stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
                bins += 1;
                (pool_o, pool_e) = (0.0, 0.0);
            }
        } else {
            stat += (observed[i] - expected[i]).powi(2) / expected[i];
            bins += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        bins += 1;
    }
    let dof = (bins - 1) as f64;
    statrs::function::gamma::gamma_ur(dof / 2.0, stat / 2.0)
}

/// Finds the leaf slot containing a point by descending with the lattice planes.
fn locate(tree: &FocalTree, y: DVec3) -> usize {
    let (mut node, mut depth, mut cell) = (0usize, 0u32, UVec3::ZERO);
    loop {
        let (lo, hi) = leaf_bounds(tree, depth.wrapping_sub(1), cell);
        let mid = if depth == 0 {
            (tree.aabb().min.as_dvec3() + tree.aabb().max.as_dvec3()) / 2.0
        } else {
            (lo + hi) / 2.0
        };
        let mut c = 0;
        for axis in 0..3 {
            c |= ((y[axis] >= mid[axis]) as usize) << axis;
        }
        cell = cell * 2 + UVec3::new(c as u32 & 1, (c as u32 >> 1) & 1, (c as u32 >> 2) & 1);
        let slot = tree.nodes()[node][c];
        if slot.index == 0 {
            return node * 8 + c;
        }
        node = slot.index as usize;
        depth += 1;
    }
}

#[test]
fn sampled_points_follow_the_leaf_probabilities() {
    let guide = trained_guide(4, 6000, 13);
    let tree = guide.converging();
    let leaves = tree.leaves();
    let mut slot_to_bin = vec![usize::MAX; tree.slot_count()];
    for (i, leaf) in leaves.iter().enumerate() {
        slot_to_bin[leaf.slot] = i;
    }
    let n = 200_000;
    let mut rng = Rng(17);
    let mut observed = vec![0.0; leaves.len()];
    for _ in 0..n {
        let y = tree
            .sample_point([rng.f64(), rng.f64(), rng.f64()])
            .unwrap();
        observed[slot_to_bin[locate(tree, y)]] += 1.0;
    }
    let expected: Vec<f64> = leaves
        .iter()
        .map(|l| n as f64 * l.density as f64 * tree.slot_volume(l.depth))
        .collect();
    let p = chi_square_p_value(&observed, &expected);
    assert!(
        p > 1e-3,
        "sample_point frequencies disagree with ρ_L V_L: p = {p}"
    );
}

#[test]
fn sampled_directions_follow_the_binned_pdf() {
    // A broad focus (segments through a ball) keeps the directional pdf smooth at the quadrature scale.
    let mut guide = FocalOctreeGuide::new(
        scene_box(),
        OctreeGuideConfig {
            threshold: 1e-2,
            ..Default::default()
        },
    )
    .unwrap();
    let mut rng = Rng(23);
    for i in 0..3 {
        let mut segments = focal_segments(&mut rng, 6000);
        for s in &mut segments {
            s.origin += (rng.sphere() * 0.25).as_vec3();
        }
        segments.extend(virtual_image_segments(&mut rng, 3000));
        guide.update_with(&segments, &context(i, 6, 1));
    }
    let x = Vec3::new(1.3, 0.85, 0.9);
    let (n_cos, n_phi, sub) = (16usize, 32usize, 12usize);
    let bin = |d: Vec3| {
        let i = (((d.z as f64 + 1.0) / 2.0 * n_cos as f64) as usize).min(n_cos - 1);
        let phi = (d.y as f64).atan2(d.x as f64).rem_euclid(2.0 * PI);
        let j = ((phi / (2.0 * PI) * n_phi as f64) as usize).min(n_phi - 1);
        i * n_phi + j
    };
    let mut expected = vec![0.0; n_cos * n_phi];
    let cell_area = (2.0 / n_cos as f64) * (2.0 * PI / n_phi as f64) / (sub * sub) as f64;
    for i in 0..n_cos {
        for j in 0..n_phi {
            let mut sum = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let z = -1.0 + (i as f64 + (a as f64 + 0.5) / sub as f64) * 2.0 / n_cos as f64;
                    let phi = (j as f64 + (b as f64 + 0.5) / sub as f64) * 2.0 * PI / n_phi as f64;
                    let r = (1.0 - z * z).sqrt();
                    sum += guide.pdf_f64(x, DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3());
                }
            }
            expected[i * n_phi + j] = sum * cell_area;
        }
    }
    let total: f64 = expected.iter().sum();
    assert!(
        (total - 1.0).abs() < 0.01,
        "quadrature of the pdf gives {total}"
    );
    let n = 200_000;
    let mut observed = vec![0.0; expected.len()];
    for _ in 0..n {
        let s = guide
            .sample_at(x, None, [rng.f32(), rng.f32(), rng.f32()])
            .unwrap();
        observed[bin(s.direction)] += 1.0;
    }
    let expected: Vec<f64> = expected.iter().map(|e| e / total * n as f64).collect();
    let p = chi_square_p_value(&observed, &expected);
    assert!(
        p > 1e-3,
        "sample() frequencies disagree with the binned pdf: p = {p}"
    );
}

#[test]
fn builds_normalise_and_conserve_mass() {
    let aabb = scene_box();
    let config = TreeConfig {
        decay: 0.5,
        ..TreeConfig::default()
    };
    let mut tree = FocalTree::new(aabb, config);
    let mut rng = Rng(29);
    let (mut splits, mut merges) = (0, 0);
    for round in 0..6 {
        // The focus moves after three rounds, so the old refinement must merge away.
        let focus = if round < 3 { FOCUS } else { VIRTUAL_FOCUS };
        let mut buffer = vec![0.0; tree.slot_count()];
        for _ in 0..4000 {
            let d = rng.sphere();
            let back = exit(aabb, focus, -d) * rng.f64();
            let o = focus - back * d;
            tree.splat(o, d, back + 0.2, 1.0, SplatStrategy::Ray, 1.0, &mut buffer);
        }
        tree.accumulate(&buffer);
        let total = tree.sum_masses();
        let report = tree.build(config.threshold * total, false);
        splits += report.splits;
        merges += report.merges;
        assert!(
            (total_probability(&tree) - 1.0).abs() < 1e-5,
            "round {round}: Σ ρV = {}",
            total_probability(&tree)
        );
        let leaf_mass: f64 = tree
            .leaves()
            .iter()
            .map(|l| tree.accumulators()[l.slot])
            .sum();
        let root_mass: f64 = tree.accumulators()[..8].iter().sum();
        for mass in [leaf_mass, root_mass] {
            assert!(
                (mass / config.decay - total).abs() <= 1e-12 * total,
                "round {round}: {mass} vs {total}"
            );
        }
    }
    assert!(splits > 0 && merges > 0, "splits {splits}, merges {merges}");

    // The final pruning build never splits and keeps the normalisation.
    let leaves_before = tree.leaf_count();
    let total = tree.sum_masses();
    let report = tree.build(config.threshold * total, true);
    assert_eq!(report.splits, 0);
    assert!(report.merges > 0 && tree.leaf_count() < leaves_before);
    assert!((total_probability(&tree) - 1.0).abs() < 1e-5);
}

#[test]
fn splat_weights_follow_the_strategies() {
    let guide = trained_guide(3, 4000, 31);
    let tree = guide.converging();
    let mut rng = Rng(37);
    for _ in 0..50 {
        let o = rng.in_box(scene_box().min.as_dvec3(), scene_box().max.as_dvec3());
        let d = rng.sphere();
        let dist = 0.5 * exit(scene_box(), o, d);
        let mut buffer = vec![0.0; tree.slot_count()];
        assert!(tree.splat(o, d, dist, 2.0, SplatStrategy::Ray, 1.0, &mut buffer));
        let sum: f64 = buffer.iter().sum();
        assert!(
            (sum - 2.0).abs() < 1e-12,
            "RAY weights must sum to c: {sum}"
        );

        let mut buffer = vec![0.0; tree.slot_count()];
        assert!(tree.splat(
            o,
            d,
            f64::INFINITY,
            2.0,
            SplatStrategy::RayWeighted,
            4.0,
            &mut buffer
        ));
        let sum: f64 = buffer.iter().sum();
        let expected = 2.0 * tree.pdf(o, d) / 4.0;
        assert!(
            (sum - expected).abs() <= 1e-12 * expected,
            "RAY_WEIGHTED weights sum to c·p/p̂"
        );
    }
    let mut buffer = vec![0.0; tree.slot_count()];
    let (o, d) = (FOCUS, DVec3::X);
    assert!(!tree.splat(o, d, 1.0, f64::NAN, SplatStrategy::Ray, 1.0, &mut buffer));
    assert!(!tree.splat(o, d, 1.0, -1.0, SplatStrategy::Ray, 1.0, &mut buffer));
    assert!(!tree.splat(o, d, 1.0, 1.0, SplatStrategy::RayWeighted, 0.0, &mut buffer));
    assert!(buffer.iter().all(|&b| b == 0.0));
}

#[test]
fn a_focal_point_is_learned_and_narrowed() {
    let iterations = 9; // narrowing from iteration 6
    let mut guide = FocalOctreeGuide::new(scene_box(), OctreeGuideConfig::default()).unwrap();
    let mut rng = Rng(41);
    let mut depth_before_narrowing = 0;
    let mut depth_narrowed = 0;
    for i in 0..iterations {
        let segments = focal_segments(&mut rng, 20_000);
        let stats = guide.update_with(&segments, &context(i, iterations, 0));
        // After update, the strategy is that of the next iteration.
        assert_eq!(guide.strategy() == SplatStrategy::RayWeighted, i + 1 >= 6);
        assert_eq!(stats.segments, 20_000);
        if i == 5 {
            depth_before_narrowing = guide.converging().max_leaf_depth();
        }
        if i == 7 {
            depth_narrowed = guide.converging().max_leaf_depth();
        }
    }
    assert!(
        depth_narrowed > depth_before_narrowing,
        "narrowing should deepen the focus: {depth_before_narrowing} -> {depth_narrowed}"
    );
    let tree = guide.converging();
    let peak = tree
        .leaves()
        .into_iter()
        .max_by(|a, b| a.density.total_cmp(&b.density))
        .unwrap();
    let (lo, hi) = leaf_bounds(tree, peak.depth, peak.cell);
    assert!(
        FOCUS.cmpge(lo).all() && FOCUS.cmple(hi).all(),
        "peak leaf {lo}..{hi} misses the focus"
    );
    let near = (0..10_000)
        .filter(|_| {
            let y = tree
                .sample_point([rng.f64(), rng.f64(), rng.f64()])
                .unwrap();
            y.distance(FOCUS) < 0.05
        })
        .count();
    assert!(
        near > 5_000,
        "only {near} of 10000 sampled points lie near the focus"
    );
    // Without glossy endpoints the diverging tree holds only floor mass.
    assert!(guide.p_div() < 1e-6, "p_div = {}", guide.p_div());
}

#[test]
fn updates_are_deterministic_for_any_thread_count() {
    let mut rng = Rng(43);
    let mut segments = focal_segments(&mut rng, 15_000);
    segments.extend(virtual_image_segments(&mut rng, 5_000));
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut guide =
                FocalOctreeGuide::new(scene_box(), OctreeGuideConfig::default()).unwrap();
            for i in 0..3 {
                // Batches of uneven size, as render passes deliver them.
                let (a, b) = segments.split_at(7_000);
                let mut samples = guide.new_samples();
                guide.add_samples(&mut samples, a);
                guide.add_samples(&mut samples, b);
                guide.update(samples, &context(i, 3, threads));
            }
            guide.save()
        })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

#[test]
fn save_load_round_trip_reproduces_the_model() {
    let guide = trained_guide(3, 5000, 47);
    let bytes = guide.save();
    let loaded = FocalOctreeGuide::load(&bytes, OctreeGuideConfig::default()).unwrap();
    assert_eq!(loaded.save(), bytes);
    assert_eq!(loaded.p_div(), guide.p_div());
    let mut rng = Rng(53);
    for _ in 0..2000 {
        let x = rng.in_box(DVec3::splat(-2.0), DVec3::splat(2.0)).as_vec3();
        let d = rng.sphere().as_vec3();
        assert_eq!(
            loaded.pdf_at(x, None, d).to_bits(),
            guide.pdf_at(x, None, d).to_bits()
        );
        let u = [rng.f32(), rng.f32(), rng.f32()];
        assert_eq!(loaded.sample_at(x, None, u), guide.sample_at(x, None, u));
    }
    assert!(
        FocalOctreeGuide::load(&bytes[..bytes.len() / 2], OctreeGuideConfig::default()).is_err()
    );
    assert!(FocalOctreeGuide::load(b"not a snapshot", OctreeGuideConfig::default()).is_err());
    let mut corrupt = bytes.clone();
    corrupt[8] ^= 0x7f; // the version
    assert!(FocalOctreeGuide::load(&corrupt, OctreeGuideConfig::default()).is_err());
}

#[test]
fn invalid_boxes_and_configs_are_rejected_and_flat_boxes_padded() {
    let config = OctreeGuideConfig::default();
    let empty = Aabb3 {
        min: Vec3::ONE,
        max: Vec3::ZERO,
    };
    assert!(FocalOctreeGuide::new(empty, config).is_err());
    let inf = Aabb3 {
        min: Vec3::ZERO,
        max: Vec3::new(f32::INFINITY, 1.0, 1.0),
    };
    assert!(FocalOctreeGuide::new(inf, config).is_err());
    assert!(FocalOctreeGuide::new(
        scene_box(),
        OctreeGuideConfig {
            threshold: 0.0,
            ..config
        }
    )
    .is_err());
    assert!(FocalOctreeGuide::new(
        scene_box(),
        OctreeGuideConfig {
            max_depth: 40,
            ..config
        }
    )
    .is_err());
    let flat = Aabb3 {
        min: Vec3::new(0.0, 0.0, 0.0),
        max: Vec3::new(1.0, 0.0, 1.0),
    };
    let guide = FocalOctreeGuide::new(flat, config).unwrap();
    assert!(guide.aabb().max.y > guide.aabb().min.y);
    let s = guide
        .sample_at(Vec3::new(0.5, 0.0, 0.5), None, [0.3, 0.6, 0.2])
        .unwrap();
    assert!(s.pdf.is_finite() && s.pdf > 0.0);
}

#[test]
fn nose_dumps_round_trip_and_drop_orphans() {
    use focal_guiding::octree::{load_nose, store_nose};
    let guide = trained_guide(3, 4000, 59);
    let tree = guide.converging();
    let bytes = store_nose(tree, SplatStrategy::RayWeighted, true);
    assert_eq!(&bytes[..4], b"ESON");
    assert_eq!(
        bytes.len(),
        4 + 10 + 24 + 4 + 4 + 28 + 4 + 96 * tree.nodes().len()
    );
    let loaded = load_nose(&bytes).unwrap();
    assert_eq!(loaded.strategy, Some(SplatStrategy::RayWeighted));
    assert!(loaded.pruning);
    assert_eq!(loaded.tree.nodes(), tree.nodes());
    assert_eq!(loaded.tree.config().max_depth, 14);
    assert!((total_probability(&loaded.tree) - 1.0).abs() < 1e-5);
    let mut rng = Rng(61);
    for _ in 0..500 {
        let x = rng.in_box(DVec3::splat(-2.0), DVec3::splat(2.0));
        let d = rng.sphere();
        assert_eq!(loaded.tree.pdf(x, d).to_bits(), tree.pdf(x, d).to_bits());
    }

    // An orphaned node (as the original's merges leave behind) is dropped.
    let count_at = bytes.len() - 96 * tree.nodes().len() - 4;
    let mut orphaned = bytes.clone();
    orphaned[count_at..count_at + 4]
        .copy_from_slice(&(tree.nodes().len() as u32 + 1).to_le_bytes());
    orphaned.extend_from_slice(&[0u8; 96]);
    let loaded = load_nose(&orphaned).unwrap();
    assert_eq!(loaded.stored_nodes, tree.nodes().len() + 1);
    assert_eq!(loaded.tree.nodes(), tree.nodes());

    // A node that lists itself as a child, a truncated file and a wrong magic are errors, not panics.
    let first_node = count_at + 4;
    let interior = tree.nodes()[0].iter().position(|s| s.index != 0).unwrap();
    let child = tree.nodes()[0][interior].index;
    let mut looped = bytes.clone();
    let at = first_node + 96 * child as usize;
    looped[at..at + 4].copy_from_slice(&child.to_le_bytes());
    assert!(load_nose(&looped).is_err());
    assert!(load_nose(&bytes[..bytes.len() - 10]).is_err());
    assert!(load_nose(b"NOSE").is_err());

    // Unlinking a subtree from the root turns it into orphans: still loadable, with fewer nodes.
    let mut unlinked = bytes.clone();
    let at = first_node + 12 * interior;
    unlinked[at..at + 4].copy_from_slice(&0u32.to_le_bytes());
    assert!(load_nose(&unlinked).unwrap().tree.nodes().len() < tree.nodes().len());
}
