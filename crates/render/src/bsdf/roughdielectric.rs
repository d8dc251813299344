//! Rough dielectric interface (Mitsuba `roughdielectric`, Walter et al. 2007 "Microfacet models for
//! refraction through rough surfaces"): microfacet reflection and refraction chosen by the Fresnel
//! reflectance of the sampled microfacet; two-sided.

use super::fresnel::{fresnel_dielectric, reflect_about, refract_about};
use super::microfacet::Microfacet;
use super::TextureAt;
use super::{is_positive, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Rough dielectric with relative IOR `eta` = interior / exterior.
#[derive(Clone, Debug)]
pub struct RoughDielectric {
    /// Microfacet distribution.
    pub distribution: Microfacet,
    /// Relative IOR (int_ior / ext_ior), ≠ 1.
    pub eta: f32,
    /// Multiplier on reflection (not physical; default 1).
    pub specular_reflectance: Texture,
    /// Multiplier on transmission (not physical; default 1).
    pub specular_transmittance: Texture,
}

/// The half vector of a pair of directions and the quantities derived from it.
struct HalfVector {
    m: Vec3,
    reflect: bool,
    /// Relative IOR in the direction of travel of a refraction.
    eta: f32,
}

impl RoughDielectric {
    /// The distribution used for sampling: Walter's roughness widening when not sampling visible
    /// normals (reduces the weights' variance), the distribution itself otherwise.
    fn sampling_distribution(&self, cos_theta_i: f32) -> Microfacet {
        if self.distribution.sample_visible {
            self.distribution
        } else {
            self.distribution
                .scaled(1.2 - 0.2 * cos_theta_i.abs().sqrt())
        }
    }

    /// The generalised half vector (oriented to +Z), or `None` when the micro- and macro-surface
    /// disagree on the sides of `wi`/`wo`.
    fn half_vector(&self, wi: Vec3, wo: Vec3) -> Option<HalfVector> {
        let (ci, co) = (wi.z, wo.z);
        if ci == 0.0 || co == 0.0 {
            return None;
        }
        let reflect = ci * co > 0.0;
        let eta = if ci > 0.0 { self.eta } else { 1.0 / self.eta };
        let h = wi + wo * if reflect { 1.0 } else { eta };
        let len2 = h.length_squared();
        if !is_positive(len2) {
            return None;
        }
        let mut m = h / len2.sqrt();
        if m.z < 0.0 {
            m = -m;
        }
        if wi.dot(m) * ci <= 0.0 || wo.dot(m) * co <= 0.0 {
            return None;
        }
        Some(HalfVector { m, reflect, eta })
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        let Some(HalfVector { m, reflect, eta }) = self.half_vector(wi, wo) else {
            return Rgb::ZERO;
        };
        let dist = &self.distribution;
        let d = dist.eval(m);
        if d == 0.0 {
            return Rgb::ZERO;
        }
        let f = fresnel_dielectric(wi.dot(m), self.eta).f;
        let g = dist.g(wi, wo, m);
        if reflect {
            self.specular_reflectance.at(ctx) * (f * d * g / (4.0 * wi.z.abs()))
        } else {
            let (im, om) = (wi.dot(m), wo.dot(m));
            let denom = im + eta * om;
            // Radiance transport: the 1/η² solid-angle compression.
            let scale = 1.0 / (eta * eta);
            let value = scale * (1.0 - f) * d * g * eta * eta * im * om / (wi.z * denom * denom);
            self.specular_transmittance.at(ctx) * value.abs()
        }
    }

    pub(super) fn pdf(&self, _ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        let Some(HalfVector { m, reflect, eta }) = self.half_vector(wi, wo) else {
            return 0.0;
        };
        let om = wo.dot(m);
        let dwh_dwo = if reflect {
            1.0 / (4.0 * om)
        } else {
            let denom = wi.dot(m) + eta * om;
            eta * eta * om / (denom * denom)
        };
        let wi_up = if wi.z < 0.0 { -wi } else { wi };
        let prob = self.sampling_distribution(wi.z).pdf(wi_up, m);
        let f = fresnel_dielectric(wi.dot(m), self.eta).f;
        let sel = if reflect { f } else { 1.0 - f };
        (prob * sel * dwh_dwo).abs()
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let ci = wi.z;
        if ci == 0.0 {
            return None;
        }
        let wi_up = if ci < 0.0 { -wi } else { wi };
        let sampling = self.sampling_distribution(ci);
        let (m, m_pdf) = sampling.sample(wi_up, u2);
        if !is_positive(m_pdf) {
            return None;
        }
        // Microfacets facing away from wi (possible when sampling the full NDF) carry no energy, and
        // pdf() could not attribute their directions to them.
        if wi.dot(m) * ci <= 0.0 {
            return None;
        }
        let fr = fresnel_dielectric(wi.dot(m), self.eta);
        let dist = &self.distribution;
        let (wo, pdf, mut weight, eta) = if u1 < fr.f {
            let wo = reflect_about(wi, m);
            if wo.z * ci <= 0.0 {
                return None;
            }
            let pdf = m_pdf * fr.f / (4.0 * wo.dot(m)).abs();
            (wo, pdf, self.specular_reflectance.at(ctx), 1.0)
        } else {
            let wo = refract_about(wi, m, fr.cos_theta_t, fr.eta_ti);
            if wo.z * ci >= 0.0 {
                return None;
            }
            let om = wo.dot(m);
            let denom = wi.dot(m) + fr.eta_it * om;
            let pdf = (m_pdf * (1.0 - fr.f) * fr.eta_it * fr.eta_it * om / (denom * denom)).abs();
            let scale = fr.eta_ti * fr.eta_ti;
            (
                wo,
                pdf,
                self.specular_transmittance.at(ctx) * scale,
                fr.eta_it,
            )
        };
        if wo.dot(m) * wo.z <= 0.0 {
            return None;
        }
        let g = if dist.sample_visible {
            dist.smith_g1(wo, m)
        } else {
            // Generic ratio of the unwidened model to the widened sampling density.
            let d = dist.eval(m);
            let ds = sampling.eval(m);
            if !is_positive(ds) {
                return None;
            }
            dist.g(wi, wo, m) * wi.dot(m).abs() * d / (ci.abs() * m.z * ds)
        };
        weight *= g;
        if !is_positive(pdf) || !pdf.is_finite() || !weight.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight,
            eta,
            delta: false,
        })
    }
}
