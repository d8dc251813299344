//! One focal orthtree (Rath, Yazici & Slusallek 2023): an adaptive octree over the scene box holding a
//! piecewise-constant spatial density ρ with ∫ρ dV = 1, learned from splatted path segments.
//!
//! Faithful to the authors' `focal_guiding::Orthtree` (`docs/design/octree.md` §2–§4),
//! with these documented, distribution-preserving deviations:
//! - accumulators are `f64` and live in a separate array (the node array holds only child index and
//!   density); the renderer's splats are summed per chunk in a fixed order instead of atomics;
//! - a build writes a fresh, compact pre-order node array, so a collapsed subtree is deleted as a whole
//!   (the original leaks the descendants of a merged node as unreachable orphans);
//! - ray traversal is a plain recursive walk with exact slab tests per child box (the original's
//!   Revelles walk from a degenerate entry child gives the same leaves and intervals), in `f64`;
//! - the hierarchical sample warp runs in `f64`, so the in-leaf position keeps more bits.

use glam::{DVec3, UVec3};
use serde::{Deserialize, Serialize};

use crate::Aabb3;

/// Accumulator floor applied before summing (keeps every density strictly positive and, applied to an
/// empty tree, produces the initial 16³ grid).
pub const ACCUMULATOR_FLOOR: f64 = 1e-20;
/// Clamp of the box volume used for densities (the original's guard against infinite boxes).
const MAX_ROOT_VOLUME: f64 = 1e20;
/// A zero direction component is replaced by this value so the slab test never forms 0·∞.
const ZERO_DIRECTION_SUBSTITUTE: f64 = 1e-10;
/// Deepest slot depth any tree may have (lattice coordinates and dyadic fractions stay exact).
pub const MAX_SUPPORTED_DEPTH: u32 = 24;
/// The largest f64 below 1, for clamping warped random numbers.
const ONE_MINUS_EPSILON: f64 = 1.0 - f64::EPSILON / 2.0;

/// How a segment's contribution is divided among the leaves it crosses (§3.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SplatStrategy {
    /// Each leaf gets its length fraction (t_out − t_in)/D of the clipped segment.
    Ray,
    /// "Iterative narrowing": each leaf gets its share ρ_L (t_out³ − t_in³)/3 / p̂ of the probability of
    /// having generated the direction.
    RayWeighted,
}

/// Build parameters of one tree (the original's `Orthtree::Configuration`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TreeConfig {
    /// Relative split threshold (fraction of the total mass; `orth.threshold`).
    pub threshold: f64,
    /// Multiplier applied to every accumulator after a build (`orth.decay`).
    pub decay: f64,
    /// Slots shallower than this are always split.
    pub min_depth: u32,
    /// Slots at this depth or deeper are never split (leaves exist at depths 0..=max_depth).
    pub max_depth: u32,
}

impl Default for TreeConfig {
    fn default() -> Self {
        Self {
            threshold: 1e-3,
            decay: 0.5,
            min_depth: 0,
            max_depth: 14,
        }
    }
}

/// One of a node's 8 child slots. Child (stratum) `c` is the upper half along axis `a` iff bit `a` of
/// `c` is set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ChildSlot {
    /// 0 for a leaf, otherwise the index of the child node.
    pub index: u32,
    /// Normalised density per unit world volume (for an interior slot: the mean of its subtree).
    pub density: f32,
}

/// A node: its 8 child slots.
pub type Node = [ChildSlot; 8];

/// A leaf crossed by a ray, with the clipped parameter interval inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafHit {
    /// Slot id `node * 8 + child` (indexes the accumulator array).
    pub slot: usize,
    /// Slot depth (the root's children have depth 0).
    pub depth: u32,
    /// The leaf's normalised density.
    pub density: f32,
    /// Entry parameter, clipped to ≥ 0.
    pub t_in: f64,
    /// Exit parameter, clipped to ≤ t_max.
    pub t_out: f64,
}

/// A leaf of the tree with its position in the dyadic lattice of its depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafInfo {
    /// Slot id `node * 8 + child`.
    pub slot: usize,
    /// Slot depth (the root's children have depth 0).
    pub depth: u32,
    /// Integer cell coordinates at resolution 2^(depth+1) per axis.
    pub cell: UVec3,
    /// Normalised density.
    pub density: f32,
}

/// Per-slot results of [`FocalTree::sum_masses`] consumed by the next [`FocalTree::build`].
#[derive(Clone, Debug)]
struct MassSummary {
    total: f64,
    /// Largest unnormalised leaf density inside each slot's subtree (pruning mode only).
    max_density: Vec<f64>,
}

/// What a build changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildReport {
    /// Leaves turned into interior nodes (counted once per new node).
    pub splits: u64,
    /// Interior slots collapsed into leaves.
    pub merges: u64,
}

/// One focal orthtree over a box: a flat pre-order node array (index 0 is the always-interior root) plus
/// one `f64` training accumulator per slot.
#[derive(Clone, Debug)]
pub struct FocalTree {
    aabb: Aabb3,
    config: TreeConfig,
    nodes: Vec<Node>,
    accumulators: Vec<f64>,
    summary: Option<MassSummary>,
}

impl FocalTree {
    /// A tree over `aabb` (which must have positive finite extent on every axis), reset with
    /// [`FocalTree::clear`].
    pub fn new(aabb: Aabb3, config: TreeConfig) -> Self {
        let mut tree = Self {
            aabb,
            config,
            nodes: Vec::new(),
            accumulators: Vec::new(),
            summary: None,
        };
        tree.clear();
        tree
    }

    /// Rebuilds a tree from stored parts; the caller has validated the structure
    /// ([`FocalTree::validate_parts`]).
    pub(crate) fn from_parts(
        aabb: Aabb3,
        config: TreeConfig,
        nodes: Vec<Node>,
        accumulators: Vec<f64>,
    ) -> Self {
        Self {
            aabb,
            config,
            nodes,
            accumulators,
            summary: None,
        }
    }

    /// Checks that `nodes` form a tree in pre-order layout (every child index greater than its parent's,
    /// each node referenced once, all reachable, depth bounded) with finite non-negative values.
    pub(crate) fn validate_parts(nodes: &[Node], accumulators: &[f64]) -> Result<(), String> {
        if nodes.is_empty() {
            return Err("octree has no root node".into());
        }
        if accumulators.len() != nodes.len() * 8 {
            return Err(format!(
                "octree has {} accumulators for {} nodes",
                accumulators.len(),
                nodes.len()
            ));
        }
        if accumulators.iter().any(|a| !a.is_finite() || *a < 0.0) {
            return Err("octree accumulator is negative or not finite".into());
        }
        let mut referenced = vec![false; nodes.len()];
        let mut depth = vec![0u32; nodes.len()];
        for (parent, node) in nodes.iter().enumerate() {
            for slot in node {
                if !slot.density.is_finite() || slot.density < 0.0 {
                    return Err(format!(
                        "octree node {parent} has an invalid density {}",
                        slot.density
                    ));
                }
                if slot.index == 0 {
                    continue;
                }
                let child = slot.index as usize;
                if child <= parent || child >= nodes.len() || referenced[child] {
                    return Err(format!(
                        "octree node {parent} has an invalid child index {child}"
                    ));
                }
                referenced[child] = true;
                depth[child] = depth[parent] + 1;
                if depth[child] > MAX_SUPPORTED_DEPTH {
                    return Err("octree is deeper than supported".into());
                }
            }
        }
        if referenced.iter().skip(1).any(|r| !r) {
            return Err("octree contains unreachable nodes".into());
        }
        Ok(())
    }

    /// Resets to the original's start state: a root with 8 empty leaves, immediately built, which with
    /// threshold 1e-3 gives the uniform 16³ grid (585 nodes, 4096 leaves, §2.5).
    pub fn clear(&mut self) {
        self.nodes = vec![[ChildSlot::default(); 8]];
        self.accumulators = vec![0.0; 8];
        self.summary = None;
        let total = self.sum_masses();
        self.build(self.config.threshold * total, false);
    }

    /// The box the tree covers.
    pub fn aabb(&self) -> Aabb3 {
        self.aabb
    }

    /// The build parameters.
    pub fn config(&self) -> TreeConfig {
        self.config
    }

    /// Mutable build parameters (the guide's schedule changes decay and min depth between builds).
    pub fn config_mut(&mut self) -> &mut TreeConfig {
        &mut self.config
    }

    /// The node array (index 0 is the root).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The training accumulators, one per slot (`node * 8 + child`).
    pub fn accumulators(&self) -> &[f64] {
        &self.accumulators
    }

    /// Number of slots (the length an accumulator buffer for [`FocalTree::splat`] must have).
    pub fn slot_count(&self) -> usize {
        self.nodes.len() * 8
    }

    /// Adds a buffer of splatted mass (one value per slot) to the accumulators.
    pub fn accumulate(&mut self, mass: &[f64]) {
        assert_eq!(
            mass.len(),
            self.accumulators.len(),
            "accumulator buffer does not match the tree"
        );
        for (a, m) in self.accumulators.iter_mut().zip(mass) {
            *a += m;
        }
        self.summary = None;
    }

    /// World volume of one slot at `depth`: V_aabb / 8^(depth+1) (clamped like the original).
    pub fn slot_volume(&self, depth: u32) -> f64 {
        let extent = self.extent();
        let root = (extent.x * extent.y * extent.z).min(MAX_ROOT_VOLUME);
        root * 0.125f64.powi(depth as i32 + 1)
    }

    fn extent(&self) -> DVec3 {
        self.aabb.max.as_dvec3() - self.aabb.min.as_dvec3()
    }

    /// All leaves with their lattice cells, in pre-order.
    pub fn leaves(&self) -> Vec<LeafInfo> {
        let mut out = Vec::new();
        self.collect_leaves(0, 0, UVec3::ZERO, &mut out);
        out
    }

    fn collect_leaves(&self, node: usize, depth: u32, cell: UVec3, out: &mut Vec<LeafInfo>) {
        for (c, slot) in self.nodes[node].iter().enumerate() {
            let child_cell = cell * 2 + child_bits(c);
            if slot.index == 0 {
                out.push(LeafInfo {
                    slot: node * 8 + c,
                    depth,
                    cell: child_cell,
                    density: slot.density,
                });
            } else {
                self.collect_leaves(slot.index as usize, depth + 1, child_cell, out);
            }
        }
    }

    /// Number of leaves.
    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().flatten().filter(|s| s.index == 0).count()
    }

    /// Depth of the deepest leaf (the root's children have depth 0).
    pub fn max_leaf_depth(&self) -> u32 {
        self.leaves().iter().map(|l| l.depth).max().unwrap_or(0)
    }

    /// Step 1 of a build ("sumDensities", §2.3): floors every accumulator at 1e-20, stores subtree sums in
    /// the interior slots' accumulators, records each subtree's largest leaf density, and returns the
    /// total mass W.
    pub fn sum_masses(&mut self) -> f64 {
        let mut max_density = vec![0.0; self.accumulators.len()];
        let mut total = 0.0;
        for c in 0..8 {
            total += self.sum_slot(0, c, 0, &mut max_density);
        }
        self.summary = Some(MassSummary { total, max_density });
        total
    }

    fn sum_slot(&mut self, node: usize, c: usize, depth: u32, max_density: &mut [f64]) -> f64 {
        let slot = node * 8 + c;
        let child = self.nodes[node][c].index as usize;
        if child == 0 {
            let mass = self.accumulators[slot].max(ACCUMULATOR_FLOOR);
            self.accumulators[slot] = mass;
            max_density[slot] = mass / self.slot_volume(depth);
            mass
        } else {
            let mut mass = 0.0;
            let mut densest: f64 = 0.0;
            for cc in 0..8 {
                mass += self.sum_slot(child, cc, depth + 1, max_density);
                densest = densest.max(max_density[child * 8 + cc]);
            }
            self.accumulators[slot] = mass;
            max_density[slot] = densest;
            mass
        }
    }

    /// Step 2 of a build (§2.4): splits slots heavier than `t_abs` (spreading their mass uniformly, possibly
    /// through several levels), collapses interior slots not heavier than it, or — in `pruning` mode —
    /// only collapses subtrees whose densest leaf is below twice their mean. Then sets every density to
    /// mass / volume / W (this tree's own W) and multiplies every accumulator by the decay.
    ///
    /// Uses the sums of the preceding [`FocalTree::sum_masses`] (computed here if they are stale).
    pub fn build(&mut self, t_abs: f64, pruning: bool) -> BuildReport {
        let summary = match self.summary.take() {
            Some(s) => s,
            None => {
                self.sum_masses();
                self.summary.take().expect("sum_masses stores a summary")
            }
        };
        let volumes: Vec<f64> = (0..=MAX_SUPPORTED_DEPTH + 1)
            .map(|d| self.slot_volume(d))
            .collect();
        let mut builder = Builder {
            old_nodes: &self.nodes,
            old_mass: &self.accumulators,
            max_density: &summary.max_density,
            volumes: &volumes,
            config: self.config,
            t_abs,
            pruning,
            inv_total: 1.0 / summary.total,
            nodes: Vec::with_capacity(self.nodes.len()),
            accumulators: Vec::with_capacity(self.accumulators.len()),
            report: BuildReport::default(),
        };
        builder.build_node(NodeSource::Existing(0), 0);
        let Builder {
            nodes,
            accumulators,
            report,
            ..
        } = builder;
        self.nodes = nodes;
        self.accumulators = accumulators;
        report
    }

    /// Calls `f` for every leaf the ray `o + t·d` crosses for t in [0, t_max] with a non-empty clipped
    /// interval. `d` need not be normalised (t is in units of |d|); a zero component is replaced by
    /// +1e-10 like the original.
    pub fn for_each_leaf_on_ray(&self, o: DVec3, d: DVec3, t_max: f64, mut f: impl FnMut(LeafHit)) {
        if !o.is_finite() || !d.is_finite() || t_max.is_nan() || t_max <= 0.0 {
            return;
        }
        let d = substitute_zero_components(d);
        let query = RayQuery {
            origin: o,
            inv_dir: d.recip(),
            t_max,
            lo: self.aabb.min.as_dvec3(),
            extent: self.extent(),
            mirror: (d.x < 0.0) as usize
                | ((d.y < 0.0) as usize) << 1
                | ((d.z < 0.0) as usize) << 2,
        };
        self.visit(0, 0, UVec3::ZERO, &query, &mut f);
    }

    fn visit(
        &self,
        node: usize,
        depth: u32,
        cell: UVec3,
        q: &RayQuery,
        f: &mut impl FnMut(LeafHit),
    ) {
        // Parameters of the three planes (low, middle, high) of this node along each axis. Child boxes
        // share planes, so every leaf's slab test uses exactly the plane values a per-leaf test would.
        let scale = 0.5f64.powi(depth as i32 + 1);
        let mut planes = [[0.0f64; 3]; 3];
        for (axis, t) in planes.iter_mut().enumerate() {
            for (j, tj) in t.iter_mut().enumerate() {
                let plane =
                    lattice_plane(q.lo[axis], q.extent[axis], 2 * cell[axis] + j as u32, scale);
                *tj = (plane - q.origin[axis]) * q.inv_dir[axis];
            }
        }
        for i in 0..8 {
            // Visiting in mirrored order roughly sorts children front to back; nothing depends on it.
            let c = i ^ q.mirror;
            let mut t_in = 0.0f64;
            let mut t_out = q.t_max;
            for (axis, t) in planes.iter().enumerate() {
                let b = (c >> axis) & 1;
                let (t0, t1) = (t[b], t[b + 1]);
                t_in = t_in.max(t0.min(t1));
                t_out = t_out.min(t0.max(t1));
            }
            if t_in >= t_out {
                continue;
            }
            let slot = self.nodes[node][c];
            let child_cell = cell * 2 + child_bits(c);
            if slot.index == 0 {
                f(LeafHit {
                    slot: node * 8 + c,
                    depth,
                    density: slot.density,
                    t_in,
                    t_out,
                });
            } else {
                self.visit(slot.index as usize, depth + 1, child_cell, q, f);
            }
        }
    }

    /// Exit distance of the ray `o + t·d` (unit `d`) from the tree's box, or `None` if it misses the box
    /// for t > 0.
    pub fn exit_distance(&self, o: DVec3, d: DVec3) -> Option<f64> {
        let d = substitute_zero_components(d);
        let inv = d.recip();
        let t0 = (self.aabb.min.as_dvec3() - o) * inv;
        let t1 = (self.aabb.max.as_dvec3() - o) * inv;
        let t_near = t0.min(t1).max_element().max(0.0);
        let t_far = t0.max(t1).min_element();
        (t_near < t_far).then_some(t_far)
    }

    /// The exact solid-angle pdf of the direction `d` from `x` when a point y ~ ρ is drawn and the
    /// direction normalize(y − x) taken: ∫₀^∞ ρ(x + tω) t² dt = Σ_L ρ_L (t_out³ − t_in³)/3 over the whole
    /// ray to the box exit (no occlusion). `d` is normalised here.
    pub fn pdf(&self, x: DVec3, d: DVec3) -> f64 {
        let len = d.length();
        if !is_positive_finite(len) {
            return 0.0;
        }
        let mut pdf = 0.0;
        self.for_each_leaf_on_ray(x, d / len, f64::INFINITY, |hit| {
            pdf += hit.density as f64 * cube_difference_third(hit.t_in, hit.t_out);
        });
        pdf
    }

    /// Draws a world-space point y ~ ρ by hierarchical sample warping (§4.1): at every node the child is
    /// chosen axis by axis (x, then y among the matching 4, then z among the matching 2) in proportion to
    /// the children's densities, rescaling the used number each time; the remaining numbers place the
    /// point inside the leaf. `None` only if the densities are degenerate (all zero).
    pub fn sample_point(&self, u: [f64; 3]) -> Option<DVec3> {
        let mut u = DVec3::from_array(u).clamp(DVec3::ZERO, DVec3::splat(ONE_MINUS_EPSILON));
        let mut node = 0usize;
        let mut depth = 0u32;
        let mut cell = UVec3::ZERO;
        loop {
            let w: [f64; 8] = std::array::from_fn(|c| self.nodes[node][c].density as f64);
            let x_low = w[0] + w[2] + w[4] + w[6];
            let bx = warp_axis(&mut u.x, x_low, x_low + w[1] + w[3] + w[5] + w[7])?;
            let y_low = w[bx] + w[bx | 4];
            let by = warp_axis(&mut u.y, y_low, y_low + w[bx | 2] + w[bx | 6])?;
            let c = bx | by << 1;
            let bz = warp_axis(&mut u.z, w[c], w[c] + w[c | 4])?;
            let c = c | bz << 2;
            cell = cell * 2 + child_bits(c);
            let slot = self.nodes[node][c];
            if slot.index == 0 {
                let scale = 0.5f64.powi(depth as i32 + 1);
                let unit = (cell.as_dvec3() + u) * scale;
                return Some(self.aabb.min.as_dvec3() + unit * self.extent());
            }
            node = slot.index as usize;
            depth += 1;
        }
    }

    /// Splats one training ray (§3.3–§3.4) into `accum` (one value per slot): the ray `o + tω` for
    /// t ∈ [0, D], D = min(`dist`, exit distance from the box), with contribution `c`. `Ray` credits each
    /// leaf c·(t_out − t_in)/D; `RayWeighted` credits c·ρ_L (t_out³ − t_in³)/3 / `p_hat`. Dropped (returns
    /// false) if c is not finite or negative, `p_hat` is not > 0, or the ray misses the box.
    #[allow(clippy::too_many_arguments)]
    pub fn splat(
        &self,
        o: DVec3,
        d: DVec3,
        dist: f64,
        c: f64,
        strategy: SplatStrategy,
        p_hat: f64,
        accum: &mut [f64],
    ) -> bool {
        if !c.is_finite()
            || c < 0.0
            || p_hat.is_nan()
            || p_hat <= 0.0
            || dist.is_nan()
            || dist <= 0.0
        {
            return false;
        }
        let len = d.length();
        if !is_positive_finite(len) || !o.is_finite() {
            return false;
        }
        let d = d / len;
        let Some(t_exit) = self.exit_distance(o, d) else {
            return false;
        };
        let clipped = dist.min(t_exit);
        if clipped.is_nan() || clipped <= 0.0 {
            return false;
        }
        match strategy {
            SplatStrategy::Ray => {
                let scale = c / clipped;
                self.for_each_leaf_on_ray(o, d, clipped, |hit| {
                    add_finite(&mut accum[hit.slot], scale * (hit.t_out - hit.t_in));
                });
            }
            SplatStrategy::RayWeighted => {
                let scale = c / p_hat;
                self.for_each_leaf_on_ray(o, d, clipped, |hit| {
                    let weight =
                        scale * hit.density as f64 * cube_difference_third(hit.t_in, hit.t_out);
                    add_finite(&mut accum[hit.slot], weight);
                });
            }
        }
        true
    }
}

/// Where a child's contents come from during a build.
#[derive(Clone, Copy)]
enum NodeSource {
    /// An existing node of the old array.
    Existing(usize),
    /// A leaf being split: its mass (= accumulator after summing) is spread uniformly over 8 children.
    Split(f64),
}

/// The pre-order rebuild of one tree (§2.4), writing a fresh compact node array.
struct Builder<'a> {
    old_nodes: &'a [Node],
    old_mass: &'a [f64],
    max_density: &'a [f64],
    volumes: &'a [f64],
    config: TreeConfig,
    t_abs: f64,
    pruning: bool,
    inv_total: f64,
    nodes: Vec<Node>,
    accumulators: Vec<f64>,
    report: BuildReport,
}

impl Builder<'_> {
    fn build_node(&mut self, source: NodeSource, depth: u32) -> u32 {
        let index = self.nodes.len();
        self.nodes.push([ChildSlot::default(); 8]);
        self.accumulators.extend([0.0; 8]);
        for c in 0..8 {
            let volume = self.volumes[depth as usize];
            let (old_child, mass, max_density) = match source {
                NodeSource::Existing(node) => {
                    let slot = node * 8 + c;
                    (
                        self.old_nodes[node][c].index,
                        self.old_mass[slot],
                        self.max_density[slot],
                    )
                }
                NodeSource::Split(parent_mass) => {
                    (0, parent_mass / 8.0, parent_mass / 8.0 / volume)
                }
            };
            let is_leaf = old_child == 0;
            let stays_leaf = depth >= self.config.min_depth
                && (depth >= self.config.max_depth
                    || if self.pruning {
                        is_leaf || max_density < 2.0 * (mass / volume)
                    } else {
                        mass <= self.t_abs
                    });
            let child_index = if stays_leaf {
                if !is_leaf {
                    // Merge: the slot keeps the subtree's summed mass; the subtree is simply not copied.
                    self.report.merges += 1;
                }
                0
            } else if is_leaf {
                self.report.splits += 1;
                self.build_node(NodeSource::Split(mass), depth + 1)
            } else {
                self.build_node(NodeSource::Existing(old_child as usize), depth + 1)
            };
            self.nodes[index][c] = ChildSlot {
                index: child_index,
                density: (mass / volume * self.inv_total) as f32,
            };
            self.accumulators[index * 8 + c] = mass * self.config.decay;
        }
        index as u32
    }
}

/// A ray prepared for traversal.
struct RayQuery {
    origin: DVec3,
    inv_dir: DVec3,
    t_max: f64,
    lo: DVec3,
    extent: DVec3,
    mirror: usize,
}

/// World coordinate of lattice plane `k` at spacing `scale` (a power of two) along one axis. The single
/// formula all box computations use, so shared planes are bit-identical.
pub fn lattice_plane(lo: f64, extent: f64, k: u32, scale: f64) -> f64 {
    lo + extent * (k as f64 * scale)
}

/// The stratum bits of child `c` as a lattice offset.
fn child_bits(c: usize) -> UVec3 {
    UVec3::new(c as u32 & 1, (c as u32 >> 1) & 1, (c as u32 >> 2) & 1)
}

/// Replaces exactly-zero direction components by +1e-10 (the original's convention).
pub fn substitute_zero_components(d: DVec3) -> DVec3 {
    let fix = |v: f64| {
        if v == 0.0 {
            ZERO_DIRECTION_SUBSTITUTE
        } else {
            v
        }
    };
    DVec3::new(fix(d.x), fix(d.y), fix(d.z))
}

/// (b³ − a³)/3 without the cancellation of subtracting two large cubes.
fn cube_difference_third(a: f64, b: f64) -> f64 {
    (b - a) * (b * b + a * b + a * a) / 3.0
}

/// Chooses the low (0) or high (1) half with probability `low / total` and rescales `u` into [0, 1).
fn warp_axis(u: &mut f64, low: f64, total: f64) -> Option<usize> {
    if !is_positive_finite(total) {
        return None;
    }
    let p_low = low / total;
    let bit = if *u < p_low {
        *u /= p_low;
        0
    } else {
        *u = (*u - p_low) / (1.0 - p_low);
        1
    };
    *u = u.clamp(0.0, ONE_MINUS_EPSILON);
    Some(bit)
}

/// True for a finite value greater than zero (false for NaN).
pub(crate) fn is_positive_finite(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Adds a splat weight unless it is non-finite or negative (the original skips such weights per leaf, so
/// a pathological p̂ cannot poison the tree).
fn add_finite(accumulator: &mut f64, weight: f64) {
    if weight.is_finite() && weight >= 0.0 {
        *accumulator += weight;
    }
}
