//! The per-thread sampling distribution of a shading point (Open PGL's `SurfaceSamplingDistribution`):
//! what a field computes once per point and reuses for every sample and pdf there.

use crate::gmm::GmmDistribution;
use crate::octree::OctreeDistribution;

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
