//! The focal-guiding octree guide of Rath, Yazici & Slusallek 2023: a converging and a diverging
//! [`FocalTree`] mixed with the learned probability p_div, trained from path segments between
//! iterations (`docs/design/octree.md` §3, §4, §6).

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::tree::{
    is_positive_finite, ChildSlot, FocalTree, Node, SplatStrategy, TreeConfig, MAX_SUPPORTED_DEPTH,
};
use crate::distribution::check_snapshot_header;
use crate::{Aabb3, GuideSample, GuidingDistribution, TrainingSegment, UpdateContext, UpdateStats};

/// Segments per splatting work item. Fixed (not derived from the thread count) so the per-chunk sums,
/// reduced in chunk order, are bit-identical for any number of threads.
pub const SPLAT_CHUNK: usize = 4096;
/// Chunks splatted concurrently before their buffers are reduced (bounds memory; does not affect the
/// result, since the reduction order is always the chunk order).
const CHUNKS_PER_ROUND: usize = 16;
/// The decay the original hard-codes once iterative narrowing starts.
pub const NARROWING_DECAY: f64 = 0.25;
/// Magic prefix of [`FocalOctreeGuide::save`] snapshots.
const SNAPSHOT_MAGIC: [u8; 8] = *b"FOCALOCT";
/// Version of the snapshot layout.
const SNAPSHOT_VERSION: u32 = 1;

/// User parameters of the octree guide (the original's `orth.*` integrator keys).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OctreeGuideConfig {
    /// Relative split threshold: a slot splits when its mass exceeds threshold × (W_conv + W_div).
    pub threshold: f64,
    /// Accumulator decay per build before iterative narrowing (afterwards 0.25, as in the original).
    pub decay: f64,
    /// Forced subdivision depth (reset to 0 for the final, pruning build).
    pub min_depth: u32,
    /// Maximum slot depth (leaves of extent / 2^(max_depth+1)).
    pub max_depth: u32,
}

impl Default for OctreeGuideConfig {
    fn default() -> Self {
        let tree = TreeConfig::default();
        Self {
            threshold: tree.threshold,
            decay: tree.decay,
            min_depth: tree.min_depth,
            max_depth: tree.max_depth,
        }
    }
}

impl OctreeGuideConfig {
    fn tree_config(&self) -> TreeConfig {
        TreeConfig {
            threshold: self.threshold,
            decay: self.decay,
            min_depth: self.min_depth,
            max_depth: self.max_depth,
        }
    }

    fn validate(&self) -> Result<(), String> {
        if !(self.threshold > 0.0 && self.threshold < 1.0) {
            return Err(format!(
                "octree threshold must lie in (0, 1), got {}",
                self.threshold
            ));
        }
        if !(self.decay >= 0.0 && self.decay <= 1.0) {
            return Err(format!(
                "octree decay must lie in [0, 1], got {}",
                self.decay
            ));
        }
        if self.max_depth > MAX_SUPPORTED_DEPTH || self.min_depth > self.max_depth {
            return Err(format!(
                "octree depths must satisfy min_depth <= max_depth <= {MAX_SUPPORTED_DEPTH}, got {} and {}",
                self.min_depth, self.max_depth
            ));
        }
        Ok(())
    }
}

/// Size and shape of one tree, for statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeStats {
    /// Leaves.
    pub leaves: usize,
    /// Nodes (all reachable: builds delete collapsed subtrees).
    pub nodes: usize,
    /// Depth of the deepest leaf (root children = 0).
    pub max_depth: u32,
}

impl TreeStats {
    fn of(tree: &FocalTree) -> Self {
        Self {
            leaves: tree.leaf_count(),
            nodes: tree.nodes().len(),
            max_depth: tree.max_leaf_depth(),
        }
    }
}

/// Focal path guiding with the authors' two octrees: a direction is drawn towards a point y ~ ρ_conv
/// (probability 1 − p_div) or away from a point y ~ ρ_div (probability p_div); its pdf is
/// (1 − p_div)·p_conv(x, ω) + p_div·p_div_tree(x, −ω), exact by ray marching. Like the original it
/// samples the whole sphere and ignores the `normal` hint.
#[derive(Clone, Debug)]
pub struct FocalOctreeGuide {
    conv: FocalTree,
    div: FocalTree,
    p_div: f64,
    aabb: Aabb3,
    config: OctreeGuideConfig,
    strategy: SplatStrategy,
    pending: PendingSplats,
}

/// Splats recorded since the last build, per slot of the current trees.
#[derive(Clone, Debug, Default)]
struct PendingSplats {
    conv: Vec<f64>,
    div: Vec<f64>,
    /// Converging splats, diverging splats, dropped segments.
    counts: [u64; 3],
    segments: u64,
}

impl PendingSplats {
    fn for_trees(conv: &FocalTree, div: &FocalTree) -> Self {
        Self {
            conv: vec![0.0; conv.slot_count()],
            div: vec![0.0; div.slot_count()],
            counts: [0; 3],
            segments: 0,
        }
    }
}

impl FocalOctreeGuide {
    /// A guide over the scene box `aabb`, both trees at the uniform 16³ start grid and p_div = 0.5.
    ///
    /// Deviation: an axis of zero extent (a flat scene) is padded to 1e-3 of the largest extent (or 1 if
    /// all are zero) so every cell has a positive volume; the original would divide by a zero volume.
    pub fn new(aabb: Aabb3, config: OctreeGuideConfig) -> Result<Self, String> {
        config.validate()?;
        let aabb = aabb.padded("octree guide")?;
        let tree_config = config.tree_config();
        let conv = FocalTree::new(aabb, tree_config);
        let div = FocalTree::new(aabb, tree_config);
        let pending = PendingSplats::for_trees(&conv, &div);
        Ok(Self {
            conv,
            div,
            p_div: 0.5,
            aabb,
            config,
            strategy: SplatStrategy::Ray,
            pending,
        })
    }

    /// The converging tree (focal points in front of the shading point).
    pub fn converging(&self) -> &FocalTree {
        &self.conv
    }

    /// The diverging tree (focal points behind the shading point, e.g. virtual images).
    pub fn diverging(&self) -> &FocalTree {
        &self.div
    }

    /// Probability of sampling from the diverging tree, W_div / (W_conv + W_div) of the last build.
    pub fn p_div(&self) -> f64 {
        self.p_div
    }

    /// The (padded) box both trees cover.
    pub fn aabb(&self) -> Aabb3 {
        self.aabb
    }

    /// The user parameters.
    pub fn config(&self) -> OctreeGuideConfig {
        self.config
    }

    /// The splatting strategy of the current schedule phase.
    pub fn strategy(&self) -> SplatStrategy {
        self.strategy
    }

    /// The guide pdf in `f64`: (1 − p_div)·p_conv(x, ω) + p_div·p_div_tree(x, −ω).
    pub fn pdf_f64(&self, x: Vec3, d: Vec3) -> f64 {
        let x = x.as_dvec3();
        let d = d.as_dvec3();
        (1.0 - self.p_div) * self.conv.pdf(x, d) + self.p_div * self.div.pdf(x, -d)
    }

    /// Splats all segments into per-slot buffers (conv, div) and counts (conv splats, div splats,
    /// dropped segments).
    fn splat_segments(&self, segments: &[TrainingSegment]) -> (Vec<f64>, Vec<f64>, [u64; 3]) {
        let mut conv_total = vec![0.0; self.conv.slot_count()];
        let mut div_total = vec![0.0; self.div.slot_count()];
        let mut counts = [0u64; 3];
        let chunks: Vec<&[TrainingSegment]> = segments.chunks(SPLAT_CHUNK).collect();
        for round in chunks.chunks(CHUNKS_PER_ROUND) {
            let partials: Vec<_> = round
                .par_iter()
                .map(|chunk| self.splat_chunk(chunk))
                .collect();
            for (conv, div, c) in partials {
                add_into(&mut conv_total, &conv);
                add_into(&mut div_total, &div);
                for (total, n) in counts.iter_mut().zip(c) {
                    *total += n;
                }
            }
        }
        (conv_total, div_total, counts)
    }

    /// The §3.3 rules for one chunk. The trees and p_div are exactly those the segments were sampled
    /// with (the model is read-only during an iteration), so splatting here instead of during rendering
    /// is equivalent to the original's immediate splats.
    fn splat_chunk(&self, chunk: &[TrainingSegment]) -> (Vec<f64>, Vec<f64>, [u64; 3]) {
        let mut conv = vec![0.0; self.conv.slot_count()];
        let mut div = vec![0.0; self.div.slot_count()];
        let mut counts = [0u64; 3];
        for s in chunk {
            let c = s.weight as f64;
            let p_mix = s.pdf as f64;
            let origin = s.origin.as_dvec3();
            let dir = s.direction.as_dvec3();
            if !c.is_finite() || c < 0.0 || p_mix.is_nan() || p_mix <= 0.0 {
                counts[2] += 1;
                continue;
            }
            if c == 0.0 {
                // The original splats only segments with a positive contribution.
                continue;
            }
            let p_conv = p_mix / (1.0 - self.p_div);
            let p_div = p_mix / self.p_div;
            if s.glossy_endpoint {
                let forward = self.conv.splat(
                    origin,
                    dir,
                    f64::INFINITY,
                    c,
                    self.strategy,
                    p_conv,
                    &mut conv,
                );
                let backward = self.div.splat(
                    origin,
                    -dir,
                    f64::INFINITY,
                    c,
                    self.strategy,
                    p_div,
                    &mut div,
                );
                counts[0] += forward as u64;
                counts[1] += backward as u64;
                counts[2] += (!forward && !backward) as u64;
            } else {
                let ok = self.conv.splat(
                    origin,
                    dir,
                    s.distance as f64,
                    c,
                    self.strategy,
                    p_conv,
                    &mut conv,
                );
                counts[0] += ok as u64;
                counts[2] += (!ok) as u64;
            }
        }
        (conv, div, counts)
    }

    /// Decodes a snapshot written by [`GuidingDistribution::save`].
    pub fn load(bytes: &[u8]) -> Result<Self, String> {
        let snapshot: Snapshot = postcard::from_bytes(bytes)
            .map_err(|e| format!("not an octree guide snapshot: {e}"))?;
        check_snapshot_header(
            "octree guide",
            snapshot.magic,
            SNAPSHOT_MAGIC,
            snapshot.version,
            SNAPSHOT_VERSION,
        )?;
        snapshot.config.validate()?;
        let aabb = Aabb3 {
            min: Vec3::from_array(snapshot.aabb_min),
            max: Vec3::from_array(snapshot.aabb_max),
        };
        if aabb.padded("octree guide")? != aabb {
            return Err("octree guide snapshot has a degenerate box".into());
        }
        if !(0.0..=1.0).contains(&snapshot.p_div) {
            return Err(format!(
                "octree guide snapshot has an invalid p_div {}",
                snapshot.p_div
            ));
        }
        let strategy = if snapshot.narrowing {
            SplatStrategy::RayWeighted
        } else {
            SplatStrategy::Ray
        };
        let conv = snapshot.conv.into_tree(aabb)?;
        let div = snapshot.div.into_tree(aabb)?;
        let pending = PendingSplats::for_trees(&conv, &div);
        Ok(Self {
            conv,
            div,
            p_div: snapshot.p_div,
            aabb,
            config: snapshot.config,
            strategy,
            pending,
        })
    }
}

impl GuidingDistribution for FocalOctreeGuide {
    fn name(&self) -> &'static str {
        "octree"
    }

    /// `u[0]` picks the diverging tree with probability p_div and is rescaled to [0, 1) for reuse as the
    /// x-axis number of the hierarchical warp; `u[1]`, `u[2]` drive the y and z axes. (The original
    /// draws three fresh numbers after the tree choice; the rescaled number is uniform and independent
    /// of the choice, so the distribution is the same.)
    fn sample(&self, x: Vec3, _normal: Option<Vec3>, u: [f32; 3]) -> Option<GuideSample> {
        let mut u0 = u[0] as f64;
        let diverging = u0 < self.p_div;
        u0 = if diverging {
            u0 / self.p_div
        } else {
            (u0 - self.p_div) / (1.0 - self.p_div)
        };
        let tree = if diverging { &self.div } else { &self.conv };
        let y = tree.sample_point([u0, u[1] as f64, u[2] as f64])?;
        let to_y = y - x.as_dvec3();
        let len = to_y.length();
        if !is_positive_finite(len) {
            return None;
        }
        let dir = if diverging { -to_y / len } else { to_y / len };
        let direction = dir.as_vec3().normalize_or_zero();
        if direction == Vec3::ZERO {
            return None;
        }
        let pdf = self.pdf(x, None, direction);
        (pdf > 0.0 && pdf.is_finite()).then_some(GuideSample { direction, pdf })
    }

    fn pdf(&self, x: Vec3, _normal: Option<Vec3>, d: Vec3) -> f32 {
        let pdf = self.pdf_f64(x, d) as f32;
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// Splats the batch into the pending per-slot buffers with the strategy of the current iteration
    /// (RAY, or RAY_WEIGHTED from iteration ⌊2N/3⌋); the trees themselves are untouched until `update`.
    fn record(&mut self, segments: &[TrainingSegment]) {
        let (conv, div, counts) = self.splat_segments(segments);
        add_into(&mut self.pending.conv, &conv);
        add_into(&mut self.pending.div, &div);
        for (total, n) in self.pending.counts.iter_mut().zip(counts) {
            *total += n;
        }
        self.pending.segments += segments.len() as u64;
    }

    /// Adds the recorded splats, then builds both trees with the shared threshold
    /// thr·(W_conv + W_div), sets p_div = W_div / (W_conv + W_div), and applies the decay and splatting
    /// strategy of the iteration that follows (RAY_WEIGHTED and decay 0.25 from ⌊2N/3⌋). The build
    /// before the final render prunes and resets the minimum depth.
    fn update(&mut self, ctx: &UpdateContext) -> UpdateStats {
        let start = Instant::now();
        let narrowing_start = 2 * ctx.training_iterations / 3;
        let pending = std::mem::take(&mut self.pending);
        let counts = pending.counts;
        self.conv.accumulate(&pending.conv);
        self.div.accumulate(&pending.div);

        let next_iteration = ctx.iteration + 1;
        let decay = if next_iteration >= narrowing_start {
            NARROWING_DECAY
        } else {
            self.config.decay
        };
        for tree in [&mut self.conv, &mut self.div] {
            let config = tree.config_mut();
            config.decay = decay;
            if ctx.final_build {
                config.min_depth = 0;
            }
        }
        let w_conv = self.conv.sum_masses();
        let w_div = self.div.sum_masses();
        self.p_div = w_div / (w_conv + w_div);
        let t_abs = self.config.threshold * (w_conv + w_div);
        let conv_report = self.conv.build(t_abs, ctx.final_build);
        let div_report = self.div.build(t_abs, ctx.final_build);

        let splatted_with = self.strategy;
        self.strategy = if next_iteration >= narrowing_start {
            SplatStrategy::RayWeighted
        } else {
            SplatStrategy::Ray
        };
        self.pending = PendingSplats::for_trees(&self.conv, &self.div);

        let conv_stats = TreeStats::of(&self.conv);
        let div_stats = TreeStats::of(&self.div);
        let details = vec![
            ("conv_leaves".into(), conv_stats.leaves as f64),
            ("conv_nodes".into(), conv_stats.nodes as f64),
            ("conv_max_depth".into(), conv_stats.max_depth as f64),
            ("div_leaves".into(), div_stats.leaves as f64),
            ("div_nodes".into(), div_stats.nodes as f64),
            ("div_max_depth".into(), div_stats.max_depth as f64),
            ("p_div".into(), self.p_div),
            ("w_conv".into(), w_conv),
            ("w_div".into(), w_div),
            ("splats_conv".into(), counts[0] as f64),
            ("splats_div".into(), counts[1] as f64),
            ("segments_dropped".into(), counts[2] as f64),
            (
                "splits".into(),
                (conv_report.splits + div_report.splits) as f64,
            ),
            (
                "merges".into(),
                (conv_report.merges + div_report.merges) as f64,
            ),
            (
                "narrowing".into(),
                (splatted_with == SplatStrategy::RayWeighted) as u8 as f64,
            ),
            ("pruning".into(), ctx.final_build as u8 as f64),
        ];
        UpdateStats {
            segments: pending.segments,
            model_size: (conv_stats.leaves + div_stats.leaves) as u64,
            seconds: start.elapsed().as_secs_f64(),
            details,
        }
    }

    fn save(&self) -> Vec<u8> {
        let snapshot = Snapshot {
            magic: SNAPSHOT_MAGIC,
            version: SNAPSHOT_VERSION,
            aabb_min: self.aabb.min.to_array(),
            aabb_max: self.aabb.max.to_array(),
            config: self.config,
            narrowing: self.strategy == SplatStrategy::RayWeighted,
            p_div: self.p_div,
            conv: SavedTree::of(&self.conv),
            div: SavedTree::of(&self.div),
        };
        postcard::to_stdvec(&snapshot).expect("serialising plain data cannot fail")
    }
}

/// The versioned snapshot layout.
#[derive(Serialize, Deserialize)]
struct Snapshot {
    magic: [u8; 8],
    version: u32,
    aabb_min: [f32; 3],
    aabb_max: [f32; 3],
    config: OctreeGuideConfig,
    narrowing: bool,
    p_div: f64,
    conv: SavedTree,
    div: SavedTree,
}

/// One tree in a snapshot, including its current (schedule-modified) configuration and accumulators so
/// training can continue.
#[derive(Serialize, Deserialize)]
struct SavedTree {
    config: TreeConfig,
    nodes: Vec<[(u32, f32); 8]>,
    accumulators: Vec<f64>,
}

impl SavedTree {
    fn of(tree: &FocalTree) -> Self {
        Self {
            config: tree.config(),
            nodes: tree
                .nodes()
                .iter()
                .map(|n| n.map(|s| (s.index, s.density)))
                .collect(),
            accumulators: tree.accumulators().to_vec(),
        }
    }

    fn into_tree(self, aabb: Aabb3) -> Result<FocalTree, String> {
        let config = self.config;
        OctreeGuideConfig {
            threshold: config.threshold,
            decay: config.decay,
            min_depth: config.min_depth,
            max_depth: config.max_depth,
        }
        .validate()?;
        let nodes: Vec<Node> = self
            .nodes
            .iter()
            .map(|n| n.map(|(index, density)| ChildSlot { index, density }))
            .collect();
        FocalTree::validate_parts(&nodes, &self.accumulators)?;
        Ok(FocalTree::from_parts(
            aabb,
            config,
            nodes,
            self.accumulators,
        ))
    }
}

fn add_into(total: &mut [f64], part: &[f64]) {
    for (t, p) in total.iter_mut().zip(part) {
        *t += p;
    }
}
