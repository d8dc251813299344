//! Rough plastic (Mitsuba 3 `roughplastic`): a diffuse base under a rough dielectric coating. The
//! coating reflects through a microfacet lobe; the diffuse part is attenuated by the coating's rough
//! transmittance on the way in and out and amplified by internal scattering.
//!
//! Like Mitsuba 3, we precompute at build time (i) the external transmittance t(cos θ) of the rough
//! interface, tabulated at 64 cosines and interpolated linearly, and (ii) the internal diffuse
//! reflectance, 2∫ r(μ, 1/η) μ dμ. Both integrate over visible microfacet normals with tensor
//! Gauss-Legendre quadrature (32² nodes for the transmittance, 128² for the internal reflectance), as
//! Mitsuba's `eval_transmittance` / `eval_reflectance` (see rough_interface.rs).

use super::fresnel::{fresnel_dielectric, reflect_about};
use super::microfacet::{Microfacet, MicrofacetKind};
use super::rough_interface::{
    direction_at, gauss_legendre, rough_reflectance, rough_transmittance, table_cosines,
    TransmittanceTable, TRANSMITTANCE_RES,
};
use super::TextureAt;
use super::{is_positive, texture_mean, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use crate::warp::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

/// Rough plastic (isotropic roughness).
#[derive(Clone, Debug)]
pub struct RoughPlastic {
    /// Microfacet distribution of the coating.
    pub distribution: Microfacet,
    /// Relative IOR of the coating (int_ior / ext_ior).
    pub eta: f32,
    /// Reflectance of the diffuse base.
    pub diffuse_reflectance: Texture,
    /// Multiplier on the specular reflection (not physical; `None` = 1).
    pub specular_reflectance: Option<Texture>,
    /// Account for the colour shift of internal scattering.
    pub nonlinear: bool,
    inv_eta_2: f32,
    specular_sampling_weight: f32,
    external_transmittance: TransmittanceTable,
    internal_reflectance: f32,
}

impl RoughPlastic {
    /// A rough plastic with its precomputed tables (isotropic `alpha`).
    pub fn new(
        kind: MicrofacetKind,
        alpha: f32,
        sample_visible: bool,
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Option<Texture>,
        nonlinear: bool,
    ) -> Self {
        let distribution = Microfacet::new(kind, alpha, alpha, sample_visible);
        // The tables always integrate over visible normals, whatever the sampling strategy.
        let table_dist = Microfacet {
            sample_visible: true,
            ..distribution
        };
        let mus = table_cosines();
        let dir = direction_at;
        let nodes_t = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
        let nodes_r = gauss_legendre(if 1.0 / eta > 1.0 { 32 } else { 128 });
        // (transmittance, reflectance·μ) per cosine; parallel because the tables cost ~1M microfacet samples.
        let rows: Vec<(f64, f64)> = mus
            .par_iter()
            .map(|&mu| {
                (
                    rough_transmittance(&table_dist, dir(mu), eta, &nodes_t),
                    rough_reflectance(&table_dist, dir(mu), 1.0 / eta, &nodes_r) * mu as f64,
                )
            })
            .collect();
        let external_transmittance =
            TransmittanceTable::from_values(&rows.iter().map(|r| r.0).collect::<Vec<_>>());
        let internal: f64 = rows.iter().map(|r| r.1).sum();
        let internal_reflectance = (2.0 * internal / TRANSMITTANCE_RES as f64) as f32;

        let d_mean = texture_mean(&diffuse_reflectance);
        let s_mean = specular_reflectance.as_ref().map_or(1.0, texture_mean);
        let total = d_mean + s_mean;
        RoughPlastic {
            distribution,
            eta,
            inv_eta_2: 1.0 / (eta * eta),
            specular_sampling_weight: if total > 0.0 { s_mean / total } else { 0.5 },
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
            external_transmittance,
            internal_reflectance,
        }
    }

    /// The tabulated external transmittance at cos θ = `mu`.
    fn transmittance(&self, mu: f32) -> f32 {
        self.external_transmittance.eval(mu)
    }

    /// The internal diffuse reflectance of the coating (for tests and diagnostics).
    pub fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }

    fn prob_specular(&self, t_i: f32) -> f32 {
        let ps = (1.0 - t_i) * self.specular_sampling_weight;
        let pd = t_i * (1.0 - self.specular_sampling_weight);
        if ps + pd > 0.0 {
            ps / (ps + pd)
        } else {
            0.0
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
        let dist = &self.distribution;
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        let mut value = Rgb::ZERO;
        if d > 0.0 {
            let f = fresnel_dielectric(wi.dot(h), self.eta).f;
            let g = dist.g(wi, wo, h);
            let s = self
                .specular_reflectance
                .as_ref()
                .map_or(Rgb::ONE, |t| t.at(ctx));
            value = s * (f * d * g / (4.0 * wi.z));
        }
        let t_i = self.transmittance(wi.z);
        let t_o = self.transmittance(wo.z);
        let diff = self.diffuse_reflectance.at(ctx);
        let diff = if self.nonlinear {
            diff / (Rgb::ONE - diff * self.internal_reflectance)
        } else {
            diff / (1.0 - self.internal_reflectance)
        };
        value + diff * (FRAC_1_PI * self.inv_eta_2 * wo.z * t_i * t_o)
    }

    pub(super) fn pdf(&self, _ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let prob_specular = self.prob_specular(self.transmittance(wi.z));
        let dist = &self.distribution;
        let h = (wi + wo).normalize();
        let spec = if dist.sample_visible {
            dist.eval(h) * dist.smith_g1(wi, h) / (4.0 * wi.z)
        } else {
            dist.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        prob_specular * spec + (1.0 - prob_specular) * square_to_cosine_hemisphere_pdf(wo)
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
        let prob_specular = self.prob_specular(self.transmittance(wi.z));
        let wo = if u1 < prob_specular {
            let (m, _) = self.distribution.sample(wi, u2);
            reflect_about(wi, m)
        } else {
            square_to_cosine_hemisphere(u2)
        };
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(ctx, wi, wo);
        if !is_positive(pdf) || !pdf.is_finite() {
            return None;
        }
        let weight = self.eval(ctx, wi, wo) / pdf;
        Some(BsdfSample {
            wo,
            pdf,
            weight,
            eta: 1.0,
            delta: false,
        })
    }
}
