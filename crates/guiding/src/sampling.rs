//! The per-thread sampling distribution of a shading point (Open PGL's `SurfaceSamplingDistribution`):
//! what a field computes once per point and reuses for every sample and pdf there.

use glam::{DVec3, Vec3};

/// A shading point's sampling distribution, typed per guide. A render thread keeps one and reuses it
/// for every vertex of every path, so that its buffers (several KiB for a large mixture) are allocated
/// once; [`crate::GuidingField::init`] makes it the distribution of that field at a point, switching
/// its kind if it last served another guide.
#[derive(Clone, Debug, Default)]
pub enum SamplingDistribution {
    /// Not initialised: samples nothing, pdf 0.
    #[default]
    Empty,
    /// The octree's ([`crate::octree::FocalOctreeGuide`]).
    Octree(OctreeDistribution),
    /// The Gaussian mixture's ([`crate::GmmGuide`]).
    Gmm(GmmDistribution),
}

impl SamplingDistribution {
    /// The octree's distribution, made one if it is of another kind.
    pub(crate) fn octree_mut(&mut self) -> &mut OctreeDistribution {
        if !matches!(self, SamplingDistribution::Octree(_)) {
            *self = SamplingDistribution::Octree(OctreeDistribution::default());
        }
        match self {
            SamplingDistribution::Octree(d) => d,
            _ => unreachable!("made an octree distribution above"),
        }
    }

    /// The mixture's distribution, made one if it is of another kind (keeping no buffers of the other).
    pub(crate) fn gmm_mut(&mut self) -> &mut GmmDistribution {
        if !matches!(self, SamplingDistribution::Gmm(_)) {
            *self = SamplingDistribution::Gmm(GmmDistribution::default());
        }
        match self {
            SamplingDistribution::Gmm(d) => d,
            _ => unreachable!("made a GMM distribution above"),
        }
    }
}

/// The octree's sampling distribution at a shading point: the point itself (every pdf is a ray
/// march through both trees from it, with nothing to precompute).
#[derive(Clone, Copy, Debug, Default)]
pub struct OctreeDistribution {
    pub(crate) x: Vec3,
}

/// The GMM guide's distribution at one shading point: the point in the guide's unit frame, the
/// hemisphere it samples (if any), and the `f32` kernel's per-component terms and hemisphere masses of
/// both mixtures with their total Z. A render thread keeps one (inside its
/// [`SamplingDistribution`]), so the buffers are allocated once.
#[derive(Clone, Debug)]
pub struct GmmDistribution {
    /// The shading point, unit frame.
    pub(crate) xu: DVec3,
    /// The unit normal of the sampled hemisphere; `None` for the whole sphere.
    pub(crate) normal: Option<DVec3>,
    /// Z, the guide's mass in that hemisphere (1 for the whole sphere).
    pub(crate) z: f64,
    /// The kernel's terms ([`crate::gmm::Mixture::prepare_vertex`]): converging, then diverging.
    pub(crate) terms: Vec<f32>,
    /// Every component's hemisphere mass: converging, then diverging, [`crate::gmm::MAX_COMPONENTS`] each.
    pub(crate) masses: Vec<f64>,
    /// The guide was trained when the distribution was made (else it samples nothing).
    pub(crate) active: bool,
}

impl Default for GmmDistribution {
    fn default() -> Self {
        Self {
            xu: DVec3::ZERO,
            normal: None,
            z: 1.0,
            terms: Vec::new(),
            masses: Vec::new(),
            active: false,
        }
    }
}
