//! The focal-guiding octree of Rath, Yazici & Slusallek 2023 ("Focal Path Guiding for Light Transport
//! Simulation"), the baseline method: [`FocalTree`] is one adaptive density octree, [`FocalOctreeGuide`]
//! the converging + diverging pair trained from path segments, [`load_nose`]/[`store_nose`] the authors'
//! dump format.
//!
//! This is the baseline, kept faithful to the authors' code (`docs/design/octree.md`, whose sections the
//! octree's doc comments cite as §N).
//! Deviations, all leaving the learned distribution unchanged up to float rounding:
//! - splats are applied in `update()` rather than during rendering (the model is read-only during an
//!   iteration, so this is equivalent), in fixed-size chunks with per-chunk `f64` accumulators reduced
//!   in chunk order (deterministic for any thread count) instead of f32 atomics;
//! - builds delete collapsed subtrees entirely (no orphaned nodes);
//! - traversal is an exact per-child slab walk in `f64` instead of the Revelles walk;
//! - the sample warp runs in `f64` and reuses the rescaled tree-choice number for the x axis;
//! - boxes of zero extent along an axis are padded slightly.

mod guide;
mod nose;
mod tree;

pub use guide::{FocalOctreeGuide, OctreeGuideConfig, TreeStats, NARROWING_DECAY, SPLAT_CHUNK};
pub use nose::{load_nose, store_nose, NoseTree};
pub use tree::{
    lattice_plane, substitute_zero_components, BuildReport, ChildSlot, FocalTree, LeafHit,
    LeafInfo, Node, SplatStrategy, TreeConfig, ACCUMULATOR_FLOOR, MAX_SUPPORTED_DEPTH,
};
