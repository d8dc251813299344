//! Rough conductor (Mitsuba `roughconductor`): Cook-Torrance microfacet reflection with the complex
//! Fresnel term and Smith shadowing-masking; one-sided.

use super::fresnel::{fresnel_conductor, reflect_about};
use super::microfacet::Microfacet;
use super::TextureAt;
use super::{is_positive, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Rough conductor with complex IOR η + ik.
#[derive(Clone, Debug)]
pub struct RoughConductor {
    /// Microfacet distribution (Beckmann α = 0.1 with visible-normal sampling by default).
    pub distribution: Microfacet,
    /// Real part of the relative IOR.
    pub eta: Texture,
    /// Imaginary part (absorption coefficient).
    pub k: Texture,
    /// Multiplier on the reflectance (not physical; default 1).
    pub specular_reflectance: Texture,
}

impl RoughConductor {
    fn fresnel(&self, ctx: &BsdfContext, cos_theta: f32) -> Rgb {
        fresnel_conductor(cos_theta, self.eta.at(ctx), self.k.at(ctx))
            * self.specular_reflectance.at(ctx)
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wi + wo).normalize();
        let d = self.distribution.eval(h);
        if d == 0.0 {
            return Rgb::ZERO;
        }
        let g = self.distribution.g(wi, wo, h);
        self.fresnel(ctx, wi.dot(h)) * (d * g / (4.0 * wi.z))
    }

    pub(super) fn pdf(&self, _ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        let dist = &self.distribution;
        if dist.sample_visible {
            dist.eval(h) * dist.smith_g1(wi, h) / (4.0 * wi.z)
        } else {
            dist.pdf(wi, h) / (4.0 * wo.dot(h))
        }
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
        let dist = &self.distribution;
        let (m, m_pdf) = dist.sample(wi, u2);
        if !is_positive(m_pdf) {
            return None;
        }
        let wo = reflect_about(wi, m);
        let wo_dot_m = wo.dot(m);
        if wo.z <= 0.0 || wo_dot_m <= 0.0 {
            return None;
        }
        let pdf = m_pdf / (4.0 * wo_dot_m);
        let weight = if dist.sample_visible {
            dist.smith_g1(wo, m)
        } else {
            dist.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        if !is_positive(pdf) || !weight.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: self.fresnel(ctx, wi.dot(m)) * weight,
            eta: 1.0,
            delta: false,
        })
    }
}
