//! focal-guiding: learned spatial densities for **focal path guiding**, independent of any renderer.
//!
//! A guiding distribution learns where contribution-carrying path segments cross (pinholes, lens and
//! caustic foci, narrow gaps) from training segments recorded by a renderer, and proposes directions
//! towards those regions from any shading point, with an exact solid-angle pdf for MIS. The renderer
//! records [`TrainingSegment`]s during an iteration and calls [`GuidingDistribution::update`] between
//! iterations; sampling and pdf evaluation are read-only and thread-safe.

mod distribution;
pub mod gmm;
pub mod octree;
mod segment_moment;
mod selection;

pub use distribution::{
    Aabb3, GuideSample, GuideVertex, GuidingDistribution, TrainingSegment, UpdateContext,
    UpdateStats,
};
pub use gmm::{GmmConfig, GmmGuide};
pub use selection::{
    SelectionConfig, SelectionGrid, SelectionRule, SelectionSummary, EXPLORATION_FRACTION,
    EXPLORATION_PROBABILITY, SELECTION_CANDIDATES,
};
