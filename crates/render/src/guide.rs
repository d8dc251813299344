//! Choosing and building the guiding distribution of a guided render.

use crate::geometry::Aabb;
use focal_guiding::gmm::GMM_SNAPSHOT_MAGIC;
use focal_guiding::octree::OCTREE_SNAPSHOT_MAGIC;
use focal_guiding::octree::{FocalOctreeGuide, OctreeGuideConfig};
use focal_guiding::{
    Aabb3, GmmConfig, GmmGuide, GuidingField, SelectionLayer, SnapshotHeader, GUIDE_SNAPSHOT_MAGIC,
};

/// Which guiding distribution a guided render learns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum GuidingMethod {
    /// No guide: the guided path tracer without guiding (for equal-settings comparisons).
    None,
    /// The adaptive density octree of Rath et al. 2023 (the baseline).
    Octree,
    /// The spatial Gaussian mixture fitted by EM on rays (our method).
    Gmm,
}

impl GuidingMethod {
    /// Parses a method name as the command line and scene files spell it.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "none" | "pt" => Ok(GuidingMethod::None),
            "octree" => Ok(GuidingMethod::Octree),
            "gmm" => Ok(GuidingMethod::Gmm),
            other => Err(format!(
                "unknown guiding method '{other}' (none, octree or gmm)"
            )),
        }
    }

    /// The method's name.
    pub fn name(&self) -> &'static str {
        match self {
            GuidingMethod::None => "none",
            GuidingMethod::Octree => "octree",
            GuidingMethod::Gmm => "gmm",
        }
    }
}

/// Parameters of the guiding distributions (each method reads its own).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GuideParams {
    /// The octree's `orth.*` settings.
    pub octree: OctreeGuideConfig,
    /// The mixture's settings.
    pub gmm: GmmConfig,
}

/// The box a guide covers: the scene bounds (geometry, sensor, emitters), as Rath et al.
pub fn guide_box(bounds: &Aabb) -> Aabb3 {
    Aabb3 {
        min: bounds.min,
        max: bounds.max,
    }
}

/// A fresh guide of `method` over `bounds` (`None` for [`GuidingMethod::None`]). The mixture comes with
/// its selection layer (`params.gmm.selection`: the fraction it asks for, learned per region for the
/// final render); the octree leaves the renderer's fixed fraction.
pub fn make_guide(
    method: GuidingMethod,
    bounds: &Aabb,
    params: &GuideParams,
) -> Result<Option<Box<dyn GuidingField>>, String> {
    Ok(match method {
        GuidingMethod::None => None,
        GuidingMethod::Octree => Some(Box::new(FocalOctreeGuide::new(
            guide_box(bounds),
            params.octree,
        )?)),
        GuidingMethod::Gmm => Some(Box::new(SelectionLayer::new(
            GmmGuide::new(guide_box(bounds), params.gmm)?,
            params.gmm.selection,
        )?)),
    })
}

/// Loads a guide saved with [`GuidingField::save`], recognised by the snapshot's header. A snapshot
/// holds the model, not its configuration: the guide takes `params` (the scene's and the command
/// line's) for everything else.
pub fn load_guide(bytes: &[u8], params: &GuideParams) -> Result<Box<dyn GuidingField>, String> {
    let header = SnapshotHeader::read(bytes).ok_or("not a saved guide (no snapshot header)")?;
    Ok(match header.magic {
        OCTREE_SNAPSHOT_MAGIC => Box::new(FocalOctreeGuide::load(bytes, params.octree)?),
        GMM_SNAPSHOT_MAGIC => Box::new(SelectionLayer::new(
            GmmGuide::load(bytes, params.gmm)?,
            params.gmm.selection,
        )?),
        GUIDE_SNAPSHOT_MAGIC => Box::new(SelectionLayer::load(
            bytes,
            params.gmm.selection,
            |field| GmmGuide::load(field, params.gmm),
        )?),
        other => {
            return Err(format!(
                "not a saved guide (unknown snapshot kind {:?})",
                String::from_utf8_lossy(&other)
            ))
        }
    })
}
