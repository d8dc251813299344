//! Light transport estimators. A coarse extension point: the render loop drives any [`Integrator`].

mod guided;
mod path;

pub use guided::{GuidedPathIntegrator, GuidedSettings, Roulette, GLOSSY_ROUGHNESS};
pub use path::{PathIntegrator, PathSettings};

use crate::color::Rgb;
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scene::Scene;
use focal_guiding::TrainingSegment;
use glam::Vec3;

/// Auxiliary per-sample outputs recorded at the first camera hit.
#[derive(Clone, Copy, Debug, Default)]
pub struct FirstHitAovs {
    /// Reflectance estimate of the first surface hit.
    pub albedo: Rgb,
    /// Shading normal at the first hit (world space).
    pub normal: Vec3,
    /// Distance along the camera ray to the first hit (0 if none).
    pub depth: f32,
}

/// Estimates the radiance arriving along camera rays.
pub trait Integrator: Send + Sync {
    /// One-sample estimate of the radiance along `ray`; fills `aovs` at the first hit. A training
    /// integrator appends the path's guiding segments to `training` (others leave it alone).
    fn li(
        &self,
        scene: &Scene,
        ray: Ray,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
        training: &mut Vec<TrainingSegment>,
    ) -> Rgb;
}

/// The power heuristic (β = 2) weight of a strategy with density `a` against one with density `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_infinite() {
        1.0
    } else {
        0.0
    }
}
