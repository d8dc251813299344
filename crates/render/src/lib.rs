//! focal-render: an unbiased CPU path tracer that loads Mitsuba 0.6 and Mitsuba 3 XML scenes.
//!
//! Pipeline: XML is parsed into a neutral [`desc::SceneDesc`] (plugins with typed properties and source
//! locations), which [`build`] turns into render objects ([`scene::Scene`]); an [`integrator::Integrator`]
//! estimates radiance along camera rays and [`render`] drives it over the film in parallel,
//! deterministically for a fixed seed.

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod color;
pub mod desc;
pub mod diagnostics;
pub mod emitter;
pub mod error;
pub mod eval;
pub mod film;
pub mod frame;
pub mod geometry;
pub mod guide;
pub mod guide_file;
pub mod integrator;
pub mod load;
pub mod mesh;
pub mod plugins;
pub mod ray;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod testing;
pub mod texture;
pub mod warp;

/// The guiding library this renderer links (re-exported so tools need not depend on it separately).
pub use focal_guiding as guiding;
