//! Ideal diffuse transmission (Mitsuba `difftrans`): light entering from one side leaves the other side
//! with a cosine distribution, f = T/π for directions on opposite sides, 0 for reflection. Works from
//! both sides.

use super::TextureAt;
use super::{BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use crate::warp::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Lambertian transmission with a (possibly textured) transmittance.
#[derive(Clone, Debug)]
pub struct DiffuseTransmitter {
    /// Transmittance T; f = T/π across the surface.
    pub transmittance: Texture,
}

impl DiffuseTransmitter {
    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        if !(wi.z * wo.z < 0.0) {
            return Rgb::ZERO;
        }
        self.transmittance.at(ctx) * (FRAC_1_PI * wo.z.abs())
    }

    pub(super) fn pdf(&self, _ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if !(wi.z * wo.z < 0.0) {
            return 0.0;
        }
        FRAC_1_PI * wo.z.abs()
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        _u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 || !wi.z.is_finite() {
            return None;
        }
        let mut wo = square_to_cosine_hemisphere(u2);
        let pdf = square_to_cosine_hemisphere_pdf(wo);
        if !(pdf > 0.0) {
            return None;
        }
        if wi.z > 0.0 {
            wo.z = -wo.z;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: self.transmittance.at(ctx),
            eta: 1.0,
            delta: false,
        })
    }
}
