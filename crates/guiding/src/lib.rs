//! focal-guiding: learned spatial densities for **focal path guiding**, independent of any renderer.
//!
//! A guide learns where contribution-carrying path segments cross (pinholes, lens and caustic foci,
//! narrow gaps) from training segments recorded by a renderer, and proposes directions towards those
//! regions from any shading point, with an exact solid-angle pdf for MIS. The interface follows Open
//! PGL's:
//!
//! - a [`GuidingField`] is the learned model, queried read-only while rendering and rebuilt by
//!   [`GuidingField::update`] between iterations; it saves a versioned snapshot of the model;
//! - a [`SamplingDistribution`] is one render thread's view of the field at a shading point;
//! - a [`SampleStorage`] holds what the field keeps of an iteration's [`TrainingSegment`]s until its
//!   update, owned by the renderer;
//! - a [`SelectionLayer`] puts the (learned) probability of sampling the guide rather than the BSDF
//!   over any field, and a [`Schedule`] says when both guides narrow and how their statistics decay.
//!
//! The two guides: [`octree::FocalOctreeGuide`] (Rath et al. 2023, the baseline) and [`GmmGuide`]
//! (a spatial Gaussian mixture fitted by EM, our method).

mod aabb;
mod field;
pub mod gmm;
pub mod octree;
mod sampling;
mod schedule;
mod segment;
mod segment_moment;
mod selection;
mod snapshot;
mod storage;

pub use aabb::Aabb3;
pub use field::{GuideSample, GuidingField, UpdateContext, UpdateStats};
pub use gmm::{GmmConfig, GmmGuide};
pub use sampling::SamplingDistribution;
pub use schedule::{Schedule, NARROWING_DECAY};
pub use segment::TrainingSegment;
pub use selection::{
    SelectionConfig, SelectionGrid, SelectionLayer, SelectionLayerConfig, SelectionRule,
    SelectionSamples, SelectionSummary, EXPLORATION_FRACTION, EXPLORATION_PROBABILITY,
    GUIDE_SNAPSHOT_MAGIC, SELECTION_CANDIDATES,
};
pub use snapshot::SnapshotHeader;
pub use storage::SampleStorage;
