//! Smooth conductor (Mitsuba `conductor`): a perfect mirror weighted by the complex Fresnel
//! reflectance; one-sided.

use super::fresnel::{fresnel_conductor, reflect};
use super::TextureAt;
use super::{BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Smooth conductor with complex IOR η + ik (relative to the exterior medium).
#[derive(Clone, Debug)]
pub struct Conductor {
    /// Real part of the relative IOR.
    pub eta: Texture,
    /// Imaginary part (absorption coefficient).
    pub k: Texture,
    /// Multiplier on the Fresnel reflectance (not physical; default 1).
    pub specular_reflectance: Texture,
}

impl Conductor {
    /// Fresnel reflectance times the specular reflectance at incidence `cos_theta_i`.
    pub(super) fn reflectance(&self, ctx: &BsdfContext, cos_theta_i: f32) -> Rgb {
        fresnel_conductor(cos_theta_i, self.eta.at(ctx), self.k.at(ctx))
            * self.specular_reflectance.at(ctx)
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        _u1: f32,
        _u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo: reflect(wi),
            pdf: 1.0,
            weight: self.reflectance(ctx, wi.z),
            eta: 1.0,
            delta: true,
        })
    }
}
