//! Surface scattering models (Mitsuba's BSDF plugins), evaluated in the local shading frame (normal = +Z).
//!
//! Conventions, as in Mitsuba 3: `wi` points away from the surface towards where the path came from (the
//! camera side); `wo` is the other direction (towards the light). [`Bsdf::eval`] returns f(wi, wo)·|cos θo|
//! of the non-delta components; [`Bsdf::pdf`] is the solid-angle density with which [`Bsdf::sample`] picks
//! `wo` through its non-delta components (including the lobe-selection probability); a sample that picks a
//! delta component has `delta = true` and a weight that already contains everything.

mod diffuse;

pub use diffuse::Diffuse;

use crate::color::Rgb;
use glam::{Vec2, Vec3};

/// Per-query data a BSDF may need besides the directions.
#[derive(Clone, Copy, Debug, Default)]
pub struct BsdfContext {
    /// Surface uv coordinates for texture lookups.
    pub uv: Vec2,
}

/// A sampled outgoing direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction `wo` in the local frame (unit length).
    pub wo: Vec3,
    /// Solid-angle density of `wo` (for a delta lobe: the probability of having chosen that lobe).
    pub pdf: f32,
    /// f·|cos θo| / pdf (for a delta lobe: the lobe's reflectance or transmittance over its probability).
    pub weight: Rgb,
    /// Relative index of refraction along the sampled direction (1 for reflection), for Russian roulette.
    pub eta: f32,
    /// True if a delta (perfectly specular) component was sampled.
    pub delta: bool,
}

/// A BSDF. Closed set (hot path): one variant per supported Mitsuba plugin.
#[derive(Clone, Debug)]
pub enum Bsdf {
    /// Lambertian reflection (`diffuse`).
    Diffuse(Diffuse),
}

impl Bsdf {
    /// f(wi, wo)·|cos θo| of the non-delta components.
    #[inline]
    pub fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        match self {
            Bsdf::Diffuse(b) => b.eval(ctx, wi, wo),
        }
    }

    /// Solid-angle density of sampling `wo` through the non-delta components.
    #[inline]
    pub fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse(b) => b.pdf(ctx, wi, wo),
        }
    }

    /// Samples `wo` given `wi`; `u1` selects a component, `u2` samples within it. `None` if the sample
    /// carries no energy (e.g. `wi` below a one-sided surface).
    #[inline]
    pub fn sample(&self, ctx: &BsdfContext, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(b) => b.sample(ctx, wi, u1, u2),
        }
    }

    /// True if some component is non-delta (so next-event estimation and guiding make sense).
    #[inline]
    pub fn has_smooth(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) => true,
        }
    }

    /// True if some component is a delta distribution.
    #[inline]
    pub fn has_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) => false,
        }
    }

    /// The smallest roughness of any component: infinity for diffuse, 0 for smooth specular, α for
    /// microfacet lobes (Mitsuba 0.6 `getRoughness`), used by focal guiding to spot glossy vertices.
    pub fn min_roughness(&self) -> f32 {
        match self {
            Bsdf::Diffuse(_) => f32::INFINITY,
        }
    }

    /// A rough reflectance at `uv` for the albedo AOV (diffuse + specular reflectance, clamped to [0, 1]).
    pub fn albedo(&self, ctx: &BsdfContext) -> Rgb {
        match self {
            Bsdf::Diffuse(b) => b.reflectance.eval(ctx.uv),
        }
    }
}
