//! Lambertian reflection (Mitsuba `diffuse`), one-sided.

use super::TextureAt;
use super::{BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use crate::warp::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Lambertian BSDF with a (possibly textured) reflectance.
#[derive(Clone, Debug)]
pub struct Diffuse {
    /// Albedo ρ; f = ρ/π.
    pub reflectance: Texture,
}

impl Diffuse {
    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.reflectance.at(ctx) * (FRAC_1_PI * wo.z)
    }

    pub(super) fn pdf(&self, _ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        square_to_cosine_hemisphere_pdf(wo)
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        _u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = square_to_cosine_hemisphere(u2);
        let pdf = square_to_cosine_hemisphere_pdf(wo);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: self.reflectance.at(ctx),
            eta: 1.0,
            delta: false,
        })
    }
}
