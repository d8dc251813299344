//! Smooth dielectric interface (Mitsuba `dielectric`): delta reflection and refraction chosen by the
//! Fresnel reflectance; two-sided (the exterior is the side the normal points to).

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::TextureAt;
use super::{BsdfContext, BsdfSample};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Smooth dielectric with relative IOR `eta` = interior / exterior.
#[derive(Clone, Debug)]
pub struct Dielectric {
    /// Relative IOR (int_ior / ext_ior).
    pub eta: f32,
    /// Multiplier on reflection (not physical; default 1).
    pub specular_reflectance: Texture,
    /// Multiplier on transmission (not physical; default 1).
    pub specular_transmittance: Texture,
}

impl Dielectric {
    /// Samples reflection with probability F and refraction otherwise. Refracted radiance is scaled by
    /// 1/η² (radiance transport, as Mitsuba 3 in `TransportMode::Radiance`).
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
        let fr = fresnel_dielectric(wi.z, self.eta);
        if u1 < fr.f {
            Some(BsdfSample {
                wo: reflect(wi),
                pdf: fr.f,
                weight: self.specular_reflectance.at(ctx),
                eta: 1.0,
                delta: true,
            })
        } else {
            Some(BsdfSample {
                wo: refract(wi, fr.cos_theta_t, fr.eta_ti).normalize(),
                pdf: 1.0 - fr.f,
                weight: self.specular_transmittance.at(ctx) * (fr.eta_ti * fr.eta_ti),
                eta: fr.eta_it,
                delta: true,
            })
        }
    }
}
