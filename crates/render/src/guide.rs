//! Choosing and building the guiding distribution of a guided render.

use crate::geometry::Aabb;
use focal_guiding::octree::{FocalOctreeGuide, OctreeGuideConfig};
use focal_guiding::{Aabb3, GmmConfig, GmmGuide, GuidingDistribution};

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

/// A fresh guide of `method` over `bounds` (`None` for [`GuidingMethod::None`]).
pub fn make_guide(
    method: GuidingMethod,
    bounds: &Aabb,
    params: &GuideParams,
) -> Result<Option<Box<dyn GuidingDistribution>>, String> {
    Ok(match method {
        GuidingMethod::None => None,
        GuidingMethod::Octree => Some(Box::new(FocalOctreeGuide::new(
            guide_box(bounds),
            params.octree,
        )?)),
        GuidingMethod::Gmm => Some(Box::new(GmmGuide::new(guide_box(bounds), params.gmm)?)),
    })
}

/// Loads a guide saved with [`GuidingDistribution::save`] (the method is recognised by the snapshot).
pub fn load_guide(bytes: &[u8]) -> Result<Box<dyn GuidingDistribution>, String> {
    match FocalOctreeGuide::load(bytes) {
        Ok(g) => Ok(Box::new(g)),
        Err(octree) => match GmmGuide::load(bytes) {
            Ok(g) => Ok(Box::new(g)),
            Err(gmm) => Err(format!(
                "not a saved guide (as an octree: {octree}; as a mixture: {gmm})"
            )),
        },
    }
}
