//! The octree guide's snapshot: both trees (nodes and accumulators, so that training can continue),
//! p_div, the box and the schedule's state; not the configuration, which the loader gives.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::guide::{FocalOctreeGuide, OctreeGuideConfig};
use super::tree::{ChildSlot, FocalTree, Node, SplatStrategy};
use crate::snapshot::{decode, encode};
use crate::Aabb3;

/// Magic prefix of the octree guide's snapshots.
pub const OCTREE_SNAPSHOT_MAGIC: [u8; 8] = *b"FOCALOCT";
/// Version of the snapshot layout (2: the model without the configuration, with the update count).
const SNAPSHOT_VERSION: u32 = 2;

/// The snapshot's body.
#[derive(Serialize, Deserialize)]
struct Snapshot {
    aabb_min: [f32; 3],
    aabb_max: [f32; 3],
    /// The next iteration's segments are splatted RAY_WEIGHTED.
    narrowing: bool,
    /// The final, pruning build has run.
    pruned: bool,
    updates: u32,
    p_div: f64,
    conv: SavedTree,
    div: SavedTree,
}

/// One tree in a snapshot.
#[derive(Serialize, Deserialize)]
struct SavedTree {
    nodes: Vec<[(u32, f32); 8]>,
    accumulators: Vec<f64>,
}

impl SavedTree {
    fn of(tree: &FocalTree) -> Self {
        Self {
            nodes: tree
                .nodes()
                .iter()
                .map(|n| n.map(|s| (s.index, s.density)))
                .collect(),
            accumulators: tree.accumulators().to_vec(),
        }
    }

    fn into_tree(
        self,
        aabb: Aabb3,
        config: &OctreeGuideConfig,
        pruned: bool,
    ) -> Result<FocalTree, String> {
        let nodes: Vec<Node> = self
            .nodes
            .iter()
            .map(|n| n.map(|(index, density)| ChildSlot { index, density }))
            .collect();
        FocalTree::validate_parts(&nodes, &self.accumulators)?;
        let mut tree_config = config.tree_config();
        if pruned {
            tree_config.min_depth = 0;
        }
        Ok(FocalTree::from_parts(
            aabb,
            tree_config,
            nodes,
            self.accumulators,
        ))
    }
}

impl FocalOctreeGuide {
    /// The guide's snapshot ([`crate::GuidingField::save`]).
    pub(super) fn snapshot(&self) -> Vec<u8> {
        let snapshot = Snapshot {
            aabb_min: self.aabb.min.to_array(),
            aabb_max: self.aabb.max.to_array(),
            narrowing: self.strategy == SplatStrategy::RayWeighted,
            pruned: self.pruned,
            updates: self.updates,
            p_div: self.p_div,
            conv: SavedTree::of(&self.conv),
            div: SavedTree::of(&self.div),
        };
        encode(OCTREE_SNAPSHOT_MAGIC, SNAPSHOT_VERSION, &snapshot)
    }

    /// Decodes a snapshot written by [`crate::GuidingField::save`], with `config` (the snapshot holds
    /// the model alone). Errors name what is wrong, never panic.
    pub fn load(bytes: &[u8], config: OctreeGuideConfig) -> Result<Self, String> {
        decode_snapshot(bytes, config)
    }
}

/// The guide of a snapshot, with `config`.
fn decode_snapshot(bytes: &[u8], config: OctreeGuideConfig) -> Result<FocalOctreeGuide, String> {
    config.validate()?;
    let s: Snapshot = decode(
        "octree guide",
        OCTREE_SNAPSHOT_MAGIC,
        SNAPSHOT_VERSION,
        bytes,
    )?;
    let aabb = Aabb3 {
        min: Vec3::from_array(s.aabb_min),
        max: Vec3::from_array(s.aabb_max),
    };
    if aabb.padded("octree guide")? != aabb {
        return Err("octree guide snapshot has a degenerate box".into());
    }
    if !(0.0..=1.0).contains(&s.p_div) {
        return Err(format!(
            "octree guide snapshot has an invalid p_div {}",
            s.p_div
        ));
    }
    Ok(FocalOctreeGuide {
        conv: s.conv.into_tree(aabb, &config, s.pruned)?,
        div: s.div.into_tree(aabb, &config, s.pruned)?,
        p_div: s.p_div,
        aabb,
        config,
        strategy: if s.narrowing {
            SplatStrategy::RayWeighted
        } else {
            SplatStrategy::Ray
        },
        updates: s.updates,
        pruned: s.pruned,
    })
}
