//! Mitsuba 0.6's `phong`: the energy-normalised modified Phong model, a Lambertian term plus a lobe
//! (n + 2)/(2π)·cosⁿα around the mirror direction, sampled by lobe (the specular one with its
//! (n + 1)/(2π)·cosⁿα density) as Mitsuba 0.6 does.

use super::{texture_mean, BsdfContext, BsdfSample, TextureAt};
use crate::color::Rgb;
use crate::frame::Frame;
use crate::texture::Texture;
use crate::warp::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The modified Phong BSDF.
#[derive(Clone, Debug)]
pub struct Phong {
    /// Phong exponent n (scalar texture, default 30).
    pub exponent: Texture,
    /// Specular reflectance (default 0.2).
    pub specular_reflectance: Texture,
    /// Diffuse reflectance (default 0.5).
    pub diffuse_reflectance: Texture,
    /// Probability of sampling the specular lobe: its mean reflectance's share.
    pub specular_sampling_weight: f32,
}

impl Phong {
    /// A Phong model with Mitsuba 0.6's lobe-selection weight (mean specular / mean total).
    pub fn new(exponent: Texture, specular: Texture, diffuse: Texture) -> Self {
        let (s, d) = (texture_mean(&specular), texture_mean(&diffuse));
        let w = if s + d > 0.0 { s / (s + d) } else { 0.5 };
        Phong {
            exponent,
            specular_reflectance: specular,
            diffuse_reflectance: diffuse,
            specular_sampling_weight: w,
        }
    }

    fn exponent_at(&self, ctx: &BsdfContext) -> f32 {
        self.exponent.at_1(ctx).max(0.0)
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let n = self.exponent_at(ctx);
        let alpha = wo.dot(Vec3::new(-wi.x, -wi.y, wi.z));
        let mut f = self.diffuse_reflectance.at(ctx) * FRAC_1_PI;
        if alpha > 0.0 {
            f += self.specular_reflectance.at(ctx) * ((n + 2.0) * 0.5 * FRAC_1_PI * alpha.powf(n));
        }
        f * wo.z
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let n = self.exponent_at(ctx);
        let alpha = wo.dot(Vec3::new(-wi.x, -wi.y, wi.z));
        let spec = if alpha > 0.0 {
            alpha.powf(n) * (n + 1.0) / (2.0 * PI)
        } else {
            0.0
        };
        let w = self.specular_sampling_weight;
        w * spec + (1.0 - w) * square_to_cosine_hemisphere_pdf(wo)
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = if u1 < self.specular_sampling_weight {
            let n = self.exponent_at(ctx);
            let cos_a = u2.y.powf(1.0 / (n + 1.0));
            let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
            let phi = 2.0 * PI * u2.x;
            let local = Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
            Frame::from_normal(Vec3::new(-wi.x, -wi.y, wi.z)).to_world(local)
        } else {
            square_to_cosine_hemisphere(u2)
        };
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(ctx, wi, wo);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: self.eval(ctx, wi, wo) / pdf,
            eta: 1.0,
            delta: false,
        })
    }

    /// Mitsuba 0.6's roughness of the specular lobe, √(2/(n + 2)).
    pub fn roughness(&self) -> f32 {
        (2.0 / (2.0 + texture_mean(&self.exponent).max(0.0))).sqrt()
    }
}
