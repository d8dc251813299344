//! The focal-guiding octree of Rath, Yazici & Slusallek 2023 ("Focal Path Guiding for Light Transport
//! Simulation"), the baseline method: [`FocalTree`] is one adaptive density octree, [`FocalOctreeGuide`]
//! the converging + diverging pair trained from path segments.

mod guide;
mod nose;
mod tree;

pub use guide::{FocalOctreeGuide, OctreeGuideConfig, TreeStats, NARROWING_DECAY, SPLAT_CHUNK};
pub use nose::{load_nose, store_nose, NoseTree};
pub use tree::{
    lattice_plane, substitute_zero_components, BuildReport, ChildSlot, FocalTree, LeafHit,
    LeafInfo, Node, SplatStrategy, TreeConfig, ACCUMULATOR_FLOOR, MAX_SUPPORTED_DEPTH,
};
