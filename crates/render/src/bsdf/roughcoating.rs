//! Rough dielectric coating (Mitsuba 0.6 `roughcoating`): a microfacet reflection at a rough interface
//! over the nested BSDF, which sees both directions refracted through the smooth mean surface. The
//! nested part is attenuated by the rough interface's transmittances t(|cos θᵢ|)·t(|cos θₒ|)
//! (rough_interface.rs), the layer's absorption exp(−σₐ·d·(1/|cos θᵢ'| + 1/|cos θₒ'|)) and scaled by the
//! compression of solid angle (1/η²)·|cos θₒ|/|cos θₒ'|, as in Mitsuba 0.6.
//!
//! Sampling: the microfacet lobe with probability (1 − tᵢ)·w / ((1 − tᵢ)·w + tᵢ·(1 − w)),
//! w = 1 / (1 + mean(exp(−2·σₐ·d))), else the nested BSDF at the refracted `wi`. Smooth samples report
//! the full pdf and eval/pdf (Mitsuba 0.6 recomputes both too). A delta sample of the nested model
//! keeps the probability of having chosen it (Mitsuba 0.6 drops the 1 − p of the lobe choice there).
//! The interface reflects on both sides, as Mitsuba 0.6's front- and back-side glossy component.

use super::coating::{refract_keep_side, CoatingLayer};
use super::fresnel::{fresnel_dielectric, reflect_about};
use super::microfacet::Microfacet;
use super::rough_interface::TransmittanceTable;
use super::TextureAt;
use super::{is_positive, Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use glam::{Vec2, Vec3};

/// A nested BSDF under a rough dielectric layer (isotropic roughness).
#[derive(Clone, Debug)]
pub struct RoughCoating {
    /// The coated material (not transmissive).
    pub nested: Bsdf,
    /// Microfacet distribution of the interface.
    pub distribution: Microfacet,
    /// The layer.
    pub layer: CoatingLayer,
    transmittance: TransmittanceTable,
}

/// Mirrors `w` into the upper hemisphere when `flip`.
#[inline]
fn side(w: Vec3, flip: bool) -> Vec3 {
    if flip {
        Vec3::new(w.x, w.y, -w.z)
    } else {
        w
    }
}

impl RoughCoating {
    /// `nested` under a rough `layer`, with its precomputed transmittance table.
    pub fn new(nested: Bsdf, distribution: Microfacet, layer: CoatingLayer) -> Self {
        RoughCoating {
            transmittance: TransmittanceTable::new(&distribution, layer.eta),
            nested,
            distribution,
            layer,
        }
    }

    /// The microfacet reflection f·cos θₒ and its sampling density, for `wi`, `wo` on the same side.
    #[inline]
    fn specular(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if !(wi.z * wo.z > 0.0) {
            return (Rgb::ZERO, 0.0);
        }
        let flip = wi.z < 0.0;
        let (wi, wo) = (side(wi, flip), side(wo, flip));
        let dist = &self.distribution;
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        if !(d > 0.0) {
            return (Rgb::ZERO, 0.0);
        }
        let f = fresnel_dielectric(wi.dot(h), self.layer.eta).f;
        let value =
            self.layer.specular_reflectance.at(ctx) * (f * d * dist.g(wi, wo, h) / (4.0 * wi.z));
        let pdf = if dist.sample_visible {
            d * dist.smith_g1(wi, h) / (4.0 * wi.z)
        } else {
            dist.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        (value, pdf)
    }

    /// The nested part: f·cos θₒ and its density (without the lobe choice), through the interface.
    #[inline]
    fn nested_part(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        let (wi_p, r12) = refract_keep_side(wi, self.layer.eta);
        let (wo_p, r21) = refract_keep_side(wo, self.layer.eta);
        if !(r12 < 1.0 && r21 < 1.0 && wo_p.z != 0.0) {
            return (Rgb::ZERO, 0.0);
        }
        let compression = self.layer.compression(wo, wo_p);
        let pdf = self.nested.pdf(ctx, wi_p, wo_p) * compression;
        let f = self.nested.eval(ctx, wi_p, wo_p);
        if f == Rgb::ZERO {
            return (f, pdf);
        }
        let t = self.transmittance.eval(wi.z.abs()) * self.transmittance.eval(wo.z.abs());
        (
            f * self.layer.absorption(ctx, wi_p, wo_p) * (t * compression),
            pdf,
        )
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        self.specular(ctx, wi, wo).0 + self.nested_part(ctx, wi, wo).0
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        let t_i = self.transmittance.eval(wi.z.abs());
        let ps = self.layer.prob_specular(1.0 - t_i, t_i);
        ps * self.specular(ctx, wi, wo).1 + (1.0 - ps) * self.nested_part(ctx, wi, wo).1
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let t_i = self.transmittance.eval(wi.z.abs());
        let ps = self.layer.prob_specular(1.0 - t_i, t_i);
        let wo = if u1 < ps {
            let flip = wi.z < 0.0;
            let (m, _) = self.distribution.sample(side(wi, flip), u2);
            side(reflect_about(side(wi, flip), m), flip)
        } else {
            let (wi_p, r12) = refract_keep_side(wi, self.layer.eta);
            if !(r12 < 1.0) {
                return None;
            }
            let u1 = ((u1 - ps) / (1.0 - ps)).clamp(0.0, 1.0 - f32::EPSILON);
            let mut s = self.nested.sample(ctx, wi_p, u1, u2)?;
            let wo_p = s.wo;
            let (wo, r21) = refract_keep_side(wo_p, 1.0 / self.layer.eta);
            if !(r21 < 1.0) {
                return None;
            }
            if s.delta {
                let t = t_i * self.transmittance.eval(wo.z.abs());
                s.weight = s.weight * self.layer.absorption(ctx, wi_p, wo_p) * (t / (1.0 - ps));
                s.pdf *= 1.0 - ps;
                s.wo = wo;
                return Some(s);
            }
            wo
        };
        let pdf = self.pdf(ctx, wi, wo);
        if !is_positive(pdf) || !pdf.is_finite() {
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

    /// Reflectance at normal incidence: the interface's plus what the nested model returns through it.
    pub(super) fn albedo(&self, ctx: &BsdfContext) -> Rgb {
        let f = fresnel_dielectric(1.0, self.layer.eta).f;
        let t = self.transmittance.eval(1.0);
        self.layer.specular_reflectance.at(ctx) * f + self.nested.albedo(ctx) * (t * t)
    }
}
