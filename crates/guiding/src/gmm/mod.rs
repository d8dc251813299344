//! Focal path guiding with a spatial Gaussian mixture (`docs/design/gmm.md`): the
//! project's own method, the successor of the [`crate::octree`] baseline.
//!
//! - [`GmmGuide`] is the guide: converging and diverging mixtures, exact directional pdf, hemisphere
//!   truncation, training from recorded segments by stepwise weighted MAP-EM;
//! - [`Gaussian3`], [`Mixture`], [`LineGaussian`]: the density and its restriction to a line;
//! - [`OriginModel`]: where each component's rays start, which makes the component weights depend on
//!   the shading point;
//! - [`special`] (erfc, erfcx, Φ⁻¹), [`special32`] (the renderer kernel's `f32` e^x, H and Φ),
//!   [`truncated`] (truncated normal and half-space sampling),
//!   [`em`] (the fit) and [`rays`] (training rays and points) are public so tests and tools can check
//!   each piece on its own.

mod columns;
mod cumulative;
mod directional_pdf;
pub mod em;
mod gaussian;
mod guide;
mod mixture;
mod origins;
pub mod rays;
pub mod reflected;
pub mod special;
pub mod special32;
mod sym3;
pub mod truncated;

pub use directional_pdf::LineGaussian;
pub use em::{FitParams, FitReport, SplitCandidate, SuffStats};
pub use gaussian::Gaussian3;
pub use guide::{GmmConfig, GmmGuide, MIN_HEMISPHERE_MASS, NARROWING_DECAY};
pub use mixture::{Mixture, MAX_COMPONENTS, TERMS_PER_COMPONENT};
pub use origins::{fit_origins, OriginModel, OriginParams};
pub use rays::{TrainingRay, WeightedPoint};
pub use sym3::{Lower3, Sym3};
