//! Reader and writer for the authors' `.nose` octree dumps (`<output>.conv.nose`, `<output>.div.nose`,
//! `docs/design/octree.md` §7), so their shipped trees can be evaluated with this port and ours viewed in
//! their visualizer.
//!
//! Layout (little-endian, single precision): "NOSE" magic (bytes `ESON`), type sizes 4, 12, 12, 24, 8
//! (u16 each), the AABB (6 × f32), "ORTH" magic (bytes `HTRO`), sizes 28 and 96 (u16), the 28-byte
//! configuration {bool unused + 3 pad, u32 strategy (0 stochastic, 1 ray, 2 ray-weighted), f32
//! threshold, f32 decay, i32 minDepth, i32 maxDepth, bool pruning + 3 pad}, u32 node count, then per
//! node 8 × {u32 child index, f32 accumulator, f32 density}.

use glam::Vec3;

use super::tree::{
    is_positive_finite, ChildSlot, FocalTree, Node, SplatStrategy, TreeConfig, MAX_SUPPORTED_DEPTH,
};
use crate::Aabb3;

const NOSE_MAGIC: &[u8; 4] = b"ESON";
const ORTH_MAGIC: &[u8; 4] = b"HTRO";
const TYPE_SIZES: [u16; 5] = [4, 12, 12, 24, 8];
const CONFIG_SIZE: u16 = 28;
const NODE_SIZE: u16 = 96;
const STRATEGY_STOCHASTIC: u32 = 0;
const STRATEGY_RAY: u32 = 1;
const STRATEGY_RAY_WEIGHTED: u32 = 2;

/// A tree read from a `.nose` dump, with the dump's schedule state.
#[derive(Clone, Debug)]
pub struct NoseTree {
    /// The tree, re-laid out in pre-order with unreachable (orphaned) nodes dropped.
    pub tree: FocalTree,
    /// The splatting strategy recorded in the dump (`None` for the unported stochastic strategy).
    pub strategy: Option<SplatStrategy>,
    /// Whether the dump's last build was the pruning build.
    pub pruning: bool,
    /// Nodes stored in the file, orphans included.
    pub stored_nodes: usize,
}

/// Little-endian cursor over a byte slice.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let end = self.at + N;
        let chunk = self.bytes.get(self.at..end).ok_or("truncated .nose file")?;
        self.at = end;
        Ok(chunk.try_into().expect("slice has length N"))
    }
    fn u16(&mut self) -> Result<u16, String> {
        self.take().map(u16::from_le_bytes)
    }
    fn u32(&mut self) -> Result<u32, String> {
        self.take().map(u32::from_le_bytes)
    }
    fn i32(&mut self) -> Result<i32, String> {
        self.take().map(i32::from_le_bytes)
    }
    fn f32(&mut self) -> Result<f32, String> {
        self.take().map(f32::from_le_bytes)
    }
    fn bool_padded(&mut self) -> Result<bool, String> {
        let b = self.take::<4>()?;
        Ok(b[0] != 0)
    }
}

/// Parses a `.nose` dump. Densities are taken as stored (the authors' builds normalise them);
/// accumulators are widened to `f64`.
pub fn load_nose(bytes: &[u8]) -> Result<NoseTree, String> {
    let mut r = Reader { bytes, at: 0 };
    if &r.take::<4>()? != NOSE_MAGIC {
        return Err("not a .nose file (bad NOSE magic)".into());
    }
    for expected in TYPE_SIZES {
        let size = r.u16()?;
        if size != expected {
            return Err(format!(
                ".nose type size {size} found where {expected} was expected (not a 3-D f32 dump)"
            ));
        }
    }
    let mut corners = [0.0f32; 6];
    for c in &mut corners {
        *c = r.f32()?;
    }
    let aabb = Aabb3 {
        min: Vec3::new(corners[0], corners[1], corners[2]),
        max: Vec3::new(corners[3], corners[4], corners[5]),
    };
    if !aabb.min.is_finite() || !aabb.max.is_finite() || aabb.min.cmpge(aabb.max).any() {
        return Err(format!(
            ".nose box {:?}..{:?} is not a finite box of positive volume",
            aabb.min, aabb.max
        ));
    }
    if &r.take::<4>()? != ORTH_MAGIC {
        return Err("not an octree .nose file (bad ORTH magic)".into());
    }
    if r.u16()? != CONFIG_SIZE || r.u16()? != NODE_SIZE {
        return Err(".nose configuration or node size does not match the 3-D octree layout".into());
    }
    let _unused = r.bool_padded()?;
    let strategy = match r.u32()? {
        STRATEGY_STOCHASTIC => None,
        STRATEGY_RAY => Some(SplatStrategy::Ray),
        STRATEGY_RAY_WEIGHTED => Some(SplatStrategy::RayWeighted),
        other => {
            return Err(format!(
                ".nose file has an unknown splatting strategy {other}"
            ))
        }
    };
    let threshold = r.f32()? as f64;
    let decay = r.f32()? as f64;
    let min_depth = r.i32()?;
    let max_depth = r.i32()?;
    let pruning = r.bool_padded()?;
    if !is_positive_finite(threshold) || !(0.0..=1.0).contains(&decay) {
        return Err(format!(
            ".nose file has an invalid threshold {threshold} or decay {decay}"
        ));
    }
    if min_depth < 0 || max_depth < min_depth || max_depth as u32 > MAX_SUPPORTED_DEPTH {
        return Err(format!(
            ".nose file has invalid depths {min_depth}..{max_depth}"
        ));
    }
    let config = TreeConfig {
        threshold,
        decay,
        min_depth: min_depth as u32,
        max_depth: max_depth as u32,
    };

    let count = r.u32()? as usize;
    if count == 0 || count.saturating_mul(NODE_SIZE as usize) > bytes.len().saturating_sub(r.at) {
        return Err(format!(".nose file declares {count} nodes but holds fewer"));
    }
    let mut stored = Vec::with_capacity(count);
    for _ in 0..count {
        let mut node = [(0u32, 0.0f32, 0.0f32); 8];
        for slot in &mut node {
            *slot = (r.u32()?, r.f32()?, r.f32()?);
        }
        stored.push(node);
    }

    // Re-lay the reachable nodes out in pre-order, which also drops the original's orphans.
    let mut nodes: Vec<Node> = Vec::new();
    let mut accumulators = Vec::new();
    let mut visited = vec![false; count];
    let mut stack = vec![(0usize, 0usize, 0usize, 0u32)]; // (stored node, new parent, parent slot, depth)
    while let Some((old, parent, parent_slot, depth)) = stack.pop() {
        if old >= count || std::mem::replace(&mut visited[old], true) {
            return Err(format!(
                ".nose file has an invalid or shared child index {old}"
            ));
        }
        if depth > MAX_SUPPORTED_DEPTH {
            return Err(".nose tree is deeper than supported".into());
        }
        let index = nodes.len();
        if index > 0 {
            nodes[parent][parent_slot].index = index as u32;
        }
        nodes.push([ChildSlot::default(); 8]);
        for (c, &(_, accumulator, density)) in stored[old].iter().enumerate() {
            nodes[index][c].density = density;
            accumulators.push(accumulator as f64);
        }
        // Pushed in reverse so child 0's subtree is laid out first: the same pre-order a build writes.
        for (c, &(child, _, _)) in stored[old].iter().enumerate().rev() {
            if child != 0 {
                stack.push((child as usize, index, c, depth + 1));
            }
        }
    }
    FocalTree::validate_parts(&nodes, &accumulators)?;
    Ok(NoseTree {
        tree: FocalTree::from_parts(aabb, config, nodes, accumulators),
        strategy,
        pruning,
        stored_nodes: count,
    })
}

/// Writes a tree in the `.nose` layout (accumulators narrowed to `f32`).
pub fn store_nose(tree: &FocalTree, strategy: SplatStrategy, pruning: bool) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + tree.nodes().len() * NODE_SIZE as usize);
    out.extend_from_slice(NOSE_MAGIC);
    for size in TYPE_SIZES {
        out.extend_from_slice(&size.to_le_bytes());
    }
    let aabb = tree.aabb();
    for v in aabb.min.to_array().into_iter().chain(aabb.max.to_array()) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(ORTH_MAGIC);
    out.extend_from_slice(&CONFIG_SIZE.to_le_bytes());
    out.extend_from_slice(&NODE_SIZE.to_le_bytes());
    let config = tree.config();
    out.extend_from_slice(&[0; 4]);
    let strategy = match strategy {
        SplatStrategy::Ray => STRATEGY_RAY,
        SplatStrategy::RayWeighted => STRATEGY_RAY_WEIGHTED,
    };
    out.extend_from_slice(&strategy.to_le_bytes());
    out.extend_from_slice(&(config.threshold as f32).to_le_bytes());
    out.extend_from_slice(&(config.decay as f32).to_le_bytes());
    out.extend_from_slice(&(config.min_depth as i32).to_le_bytes());
    out.extend_from_slice(&(config.max_depth as i32).to_le_bytes());
    out.extend_from_slice(&[pruning as u8, 0, 0, 0]);
    out.extend_from_slice(&(tree.nodes().len() as u32).to_le_bytes());
    for (n, node) in tree.nodes().iter().enumerate() {
        for (c, slot) in node.iter().enumerate() {
            out.extend_from_slice(&slot.index.to_le_bytes());
            out.extend_from_slice(&(tree.accumulators()[n * 8 + c] as f32).to_le_bytes());
            out.extend_from_slice(&slot.density.to_le_bytes());
        }
    }
    out
}
