//! Focal path guiding with a spatial Gaussian mixture (`docs/design/gmm.md`): the project's own
//! method, the successor of the [`crate::octree`] baseline.
//!
//! - [`GmmGuide`] is the guide: converging and diverging mixtures, exact directional pdf, hemisphere
//!   truncation, training from recorded segments by stepwise weighted MAP-EM; [`GmmConfig`] its
//!   parameters, [`GmmDistribution`] its sampling distribution at a shading point;
//! - [`Gaussian3`], [`Mixture`], [`LineGaussian`]: the density and its restriction to a line;
//! - [`special`] (erfc, erfcx, Φ⁻¹), [`special32`] (the renderer kernel's `f32` e^x, H and Φ),
//!   [`truncated`] (truncated normal and half-space sampling),
//!   [`em`] (the fit) and [`rays`] (training rays and points) are public so tests and tools can check
//!   each piece on its own.

mod columns;
mod config;
mod cumulative;
mod directional_pdf;
pub mod em;
#[cfg(feature = "experimental")]
mod experimental;
mod gaussian;
mod guide;
mod mixture;
pub mod rays;
mod samples;
mod sampling;
mod snapshot;
pub mod special;
pub mod special32;
mod sym3;
pub mod truncated;
mod update;

pub use config::{EmConfig, GmmConfig, PointsConfig};
pub use directional_pdf::LineGaussian;
pub use em::{FitParams, FitReport, SplitCandidate, SuffStats};
#[cfg(feature = "experimental")]
pub use experimental::ExperimentalConfig;
pub use gaussian::Gaussian3;
pub use guide::GmmGuide;
pub use mixture::{Mixture, MAX_COMPONENTS, TERMS_PER_COMPONENT};
pub use rays::{TrainingRay, WeightedPoint};
pub use sampling::{GmmDistribution, MIN_HEMISPHERE_MASS};
pub use snapshot::GMM_SNAPSHOT_MAGIC;
pub use sym3::{Lower3, Sym3};
pub use update::MIN_MIXTURE_SHARE;
