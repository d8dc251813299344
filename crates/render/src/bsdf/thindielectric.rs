//! Thin dielectric sheet (Mitsuba `thindielectric`): delta reflection with the reflectance of a slab
//! including inter-reflections, R' = R + T²R/(1 − R²), and straight-through transmission wo = −wi.

use super::fresnel::{fresnel_dielectric, reflect};
use super::TextureAt;
use super::{BsdfContext, BsdfSample};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Thin dielectric with relative IOR `eta` = interior / exterior.
#[derive(Clone, Debug)]
pub struct ThinDielectric {
    /// Relative IOR (int_ior / ext_ior).
    pub eta: f32,
    /// Multiplier on reflection (not physical; default 1).
    pub specular_reflectance: Texture,
    /// Multiplier on transmission (not physical; default 1).
    pub specular_transmittance: Texture,
}

impl ThinDielectric {
    /// Total reflectance of the slab at incidence |cos θ| = `cos_theta_i`.
    pub(super) fn slab_reflectance(&self, cos_theta_i: f32) -> f32 {
        let r = fresnel_dielectric(cos_theta_i.abs(), self.eta).f;
        let t = 1.0 - r;
        if r < 1.0 {
            r + t * t * r / (1.0 - r * r)
        } else {
            r
        }
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        _u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let r = self.slab_reflectance(wi.z);
        if u1 < r {
            Some(BsdfSample {
                wo: reflect(wi),
                pdf: r,
                weight: self.specular_reflectance.at(ctx),
                eta: 1.0,
                delta: true,
            })
        } else {
            Some(BsdfSample {
                wo: -wi,
                pdf: 1.0 - r,
                weight: self.specular_transmittance.at(ctx),
                eta: 1.0,
                delta: true,
            })
        }
    }
}
