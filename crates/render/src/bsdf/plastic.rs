//! Smooth plastic (Mitsuba `plastic`): a diffuse base under a smooth dielectric coating, with delta
//! specular reflection off the coating and diffuse light that refracts in and out, including the
//! internal scattering between base and coating (`fdr_int`); one-sided.

use super::fresnel::{fresnel_dielectric, fresnel_diffuse_reflectance, reflect};
use super::TextureAt;
use super::{is_positive, texture_mean, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use crate::warp::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};

/// Smooth plastic.
#[derive(Clone, Debug)]
pub struct Plastic {
    /// Relative IOR of the coating (int_ior / ext_ior).
    pub eta: f32,
    /// Reflectance of the diffuse base.
    pub diffuse_reflectance: Texture,
    /// Multiplier on the specular reflection (not physical; `None` = 1, as Mitsuba).
    pub specular_reflectance: Option<Texture>,
    /// Account for the colour shift of internal scattering (`nonlinear`).
    pub nonlinear: bool,
    /// 1/η².
    inv_eta_2: f32,
    /// Diffuse Fresnel reflectance seen from inside the coating.
    fdr_int: f32,
    /// Share of samples steered to the specular lobe before Fresnel weighting.
    specular_sampling_weight: f32,
}

impl Plastic {
    /// A plastic with precomputed internal reflectance and sampling weights.
    pub fn new(
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Option<Texture>,
        nonlinear: bool,
    ) -> Self {
        let d_mean = texture_mean(&diffuse_reflectance);
        let s_mean = specular_reflectance.as_ref().map_or(1.0, texture_mean);
        let total = d_mean + s_mean;
        Plastic {
            eta,
            inv_eta_2: 1.0 / (eta * eta),
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            specular_sampling_weight: if total > 0.0 { s_mean / total } else { 0.5 },
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        }
    }

    /// Probability of choosing the specular lobe given the Fresnel reflectance at incidence.
    fn prob_specular(&self, f_i: f32) -> f32 {
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        if ps + pd > 0.0 {
            ps / (ps + pd)
        } else {
            0.0
        }
    }

    /// Diffuse reflectance after internal scattering.
    fn diffuse(&self, ctx: &BsdfContext) -> Rgb {
        let d = self.diffuse_reflectance.at(ctx);
        if self.nonlinear {
            d / (Rgb::ONE - d * self.fdr_int)
        } else {
            d / (1.0 - self.fdr_int)
        }
    }

    pub(super) fn specular_albedo(&self, ctx: &BsdfContext) -> Rgb {
        let s = self
            .specular_reflectance
            .as_ref()
            .map_or(Rgb::ONE, |t| t.at(ctx));
        s * fresnel_dielectric(1.0, self.eta).f
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let f_i = fresnel_dielectric(wi.z, self.eta).f;
        let f_o = fresnel_dielectric(wo.z, self.eta).f;
        self.diffuse(ctx)
            * (square_to_cosine_hemisphere_pdf(wo) * self.inv_eta_2 * (1.0 - f_i) * (1.0 - f_o))
    }

    pub(super) fn pdf(&self, _ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let f_i = fresnel_dielectric(wi.z, self.eta).f;
        square_to_cosine_hemisphere_pdf(wo) * (1.0 - self.prob_specular(f_i))
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
        let f_i = fresnel_dielectric(wi.z, self.eta).f;
        let prob_specular = self.prob_specular(f_i);
        if u1 < prob_specular {
            let s = self
                .specular_reflectance
                .as_ref()
                .map_or(Rgb::ONE, |t| t.at(ctx));
            return Some(BsdfSample {
                wo: reflect(wi),
                pdf: prob_specular,
                weight: s * (f_i / prob_specular),
                eta: 1.0,
                delta: true,
            });
        }
        let prob_diffuse = 1.0 - prob_specular;
        let wo = square_to_cosine_hemisphere(u2);
        let cos_pdf = square_to_cosine_hemisphere_pdf(wo);
        if !is_positive(cos_pdf) || !is_positive(prob_diffuse) {
            return None;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).f;
        let weight =
            self.diffuse(ctx) * (self.inv_eta_2 * (1.0 - f_i) * (1.0 - f_o) / prob_diffuse);
        Some(BsdfSample {
            wo,
            pdf: cos_pdf * prob_diffuse,
            weight,
            eta: 1.0,
            delta: false,
        })
    }
}
