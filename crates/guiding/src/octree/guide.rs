//! The focal-guiding octree guide of Rath, Yazici & Slusallek 2023: a converging and a diverging
//! [`FocalTree`] mixed with the learned probability p_div, trained from path segments between
//! iterations (`docs/design/octree.md` §3, §4, §6).

use std::any::Any;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::tree::{is_positive_finite, FocalTree, SplatStrategy, TreeConfig, MAX_SUPPORTED_DEPTH};
use crate::sampling::OctreeDistribution;
use crate::{
    Aabb3, GuideSample, GuidingField, SampleStorage, SamplingDistribution, Schedule,
    SelectionLayerConfig, TrainingSegment, UpdateContext, UpdateStats,
};

/// Segments per splatting work item. Fixed (not derived from the thread count) so the per-chunk sums,
/// reduced in chunk order, are bit-identical for any number of threads.
pub const SPLAT_CHUNK: usize = 4096;
/// Chunks splatted concurrently before their buffers are reduced (bounds memory; does not affect the
/// result, since the reduction order is always the chunk order).
const CHUNKS_PER_ROUND: usize = 16;

/// User parameters of the octree guide (the original's `orth.*` integrator keys).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct OctreeGuideConfig {
    /// Relative split threshold: a slot splits when its mass exceeds threshold × (W_conv + W_div).
    pub threshold: f64,
    /// Forced subdivision depth (reset to 0 for the final, pruning build).
    pub min_depth: u32,
    /// Maximum slot depth (leaves of extent / 2^(max_depth+1)).
    pub max_depth: u32,
    /// Accumulator decay per build and iterative narrowing (`orth.decay` is its `decay`; the original
    /// always narrows, from ⌊2N/3⌋).
    pub schedule: Schedule,
    /// The selection layer a renderer puts over the guide: by default none of its own, the renderer's
    /// fixed fraction (Rath et al.'s 0.5).
    pub selection: SelectionLayerConfig,
}

impl Default for OctreeGuideConfig {
    fn default() -> Self {
        let tree = TreeConfig::default();
        Self {
            threshold: tree.threshold,
            min_depth: tree.min_depth,
            max_depth: tree.max_depth,
            schedule: Schedule {
                decay: tree.decay,
                ..Schedule::default()
            },
            selection: SelectionLayerConfig::renderers_fraction(),
        }
    }
}

impl OctreeGuideConfig {
    pub(super) fn tree_config(&self) -> TreeConfig {
        TreeConfig {
            threshold: self.threshold,
            decay: self.schedule.decay,
            min_depth: self.min_depth,
            max_depth: self.max_depth,
        }
    }

    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.threshold > 0.0 && self.threshold < 1.0) {
            return Err(format!(
                "octree threshold must lie in (0, 1), got {}",
                self.threshold
            ));
        }
        self.schedule.validate("octree")?;
        self.selection.validate()?;
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
    pub(super) conv: FocalTree,
    pub(super) div: FocalTree,
    pub(super) p_div: f64,
    pub(super) aabb: Aabb3,
    pub(super) config: OctreeGuideConfig,
    /// How the next iteration's segments are splatted (the schedule's phase).
    pub(super) strategy: SplatStrategy,
    pub(super) updates: u32,
    /// The final, pruning build has run (the trees' minimum depth is 0 since).
    pub(super) pruned: bool,
}

/// The octree's training-sample storage: the segments splatted so far, per slot of the trees they
/// were rendered with, and their counts.
#[derive(Clone, Debug, Default)]
struct OctreeSamples {
    conv: Vec<f64>,
    div: Vec<f64>,
    /// Converging splats, diverging splats, dropped segments.
    counts: [u64; 3],
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
        Ok(Self {
            conv: FocalTree::new(aabb, tree_config),
            div: FocalTree::new(aabb, tree_config),
            p_div: 0.5,
            aabb,
            config,
            strategy: SplatStrategy::Ray,
            updates: 0,
            pruned: false,
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

    /// The user parameters.
    pub fn config(&self) -> OctreeGuideConfig {
        self.config
    }

    /// The splatting strategy of the current schedule phase.
    pub fn strategy(&self) -> SplatStrategy {
        self.strategy
    }

    /// The guide pdf from `x` in `f32` (0 where not finite).
    fn pdf_from(&self, x: Vec3, d: Vec3) -> f32 {
        let pdf = self.pdf_f64(x, d) as f32;
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
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

    /// Splats the segments into `samples` with the current schedule phase's strategy.
    fn splat_into(&self, samples: &mut OctreeSamples, segments: &[TrainingSegment]) {
        let (conv, div, counts) = self.splat_segments(segments);
        add_into(&mut samples.conv, &conv);
        add_into(&mut samples.div, &div);
        for (total, n) in samples.counts.iter_mut().zip(counts) {
            *total += n;
        }
    }
}

impl GuidingField for FocalOctreeGuide {
    fn name(&self) -> &'static str {
        "octree"
    }

    fn aabb(&self) -> Aabb3 {
        self.aabb
    }

    /// Keeps the point; the octree ignores the `normal` hint (it samples the whole sphere).
    #[inline]
    fn init(&self, distribution: &mut SamplingDistribution, x: Vec3, _normal: Option<Vec3>) {
        distribution.octree_mut().x = x;
    }

    /// `u[0]` picks the diverging tree with probability p_div and is rescaled to [0, 1) for reuse as the
    /// x-axis number of the hierarchical warp; `u[1]`, `u[2]` drive the y and z axes. (The original
    /// draws three fresh numbers after the tree choice; the rescaled number is uniform and independent
    /// of the choice, so the distribution is the same.)
    fn sample(&self, distribution: &SamplingDistribution, u: [f32; 3]) -> Option<GuideSample> {
        let SamplingDistribution::Octree(OctreeDistribution { x }) = *distribution else {
            return None;
        };
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
        let pdf = self.pdf_from(x, direction);
        (pdf > 0.0 && pdf.is_finite()).then_some(GuideSample { direction, pdf })
    }

    fn pdf(&self, distribution: &SamplingDistribution, direction: Vec3) -> f32 {
        match *distribution {
            SamplingDistribution::Octree(OctreeDistribution { x }) => self.pdf_from(x, direction),
            _ => 0.0,
        }
    }

    fn new_samples(&self) -> SampleStorage {
        let samples = OctreeSamples {
            conv: vec![0.0; self.conv.slot_count()],
            div: vec![0.0; self.div.slot_count()],
            counts: [0; 3],
        };
        SampleStorage::new(self.name(), self.updates, samples)
    }

    /// Splats the batch into the storage's per-slot buffers with the strategy of the current
    /// iteration (RAY, or RAY_WEIGHTED once the schedule narrows); the trees themselves are untouched
    /// until `update`.
    fn add_samples(&self, samples: &mut SampleStorage, segments: &[TrainingSegment]) {
        self.splat_into(samples.data_mut(self.updates, segments.len()), segments);
    }

    /// Adds the stored splats, then builds both trees with the shared threshold
    /// thr·(W_conv + W_div), sets p_div = W_div / (W_conv + W_div), and applies the [`Schedule`]'s
    /// decay and splatting strategy for the iteration that follows (RAY_WEIGHTED and decay 0.25 from
    /// ⌊2N/3⌋). The build before the final render prunes and resets the minimum depth.
    fn update(&mut self, samples: SampleStorage, ctx: &UpdateContext) -> UpdateStats {
        let start = Instant::now();
        let (pending, segments) = samples.into_data::<OctreeSamples>(self.updates);
        let counts = pending.counts;
        self.conv.accumulate(&pending.conv);
        self.div.accumulate(&pending.div);

        // The accumulators now hold the data up to this iteration: the build decays them for the next.
        let next_iteration = ctx.iteration + 1;
        let schedule = self.config.schedule;
        let decay = schedule.decay_before(next_iteration, ctx.training_iterations);
        self.pruned |= ctx.final_build;
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
        self.strategy = if schedule.narrows(next_iteration, ctx.training_iterations) {
            SplatStrategy::RayWeighted
        } else {
            SplatStrategy::Ray
        };
        self.updates += 1;

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
            segments,
            model_size: (conv_stats.leaves + div_stats.leaves) as u64,
            seconds: start.elapsed().as_secs_f64(),
            details,
        }
    }

    fn updates(&self) -> u32 {
        self.updates
    }

    fn save(&self) -> Vec<u8> {
        self.snapshot()
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

fn add_into(total: &mut [f64], part: &[f64]) {
    for (t, p) in total.iter_mut().zip(part) {
        *t += p;
    }
}
