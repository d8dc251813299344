//! Smooth dielectric coating (Mitsuba 0.6 `coating`, after Weidlich and Wilkie 2007): a specular
//! reflection at the interface over the nested BSDF, which sees both directions refracted into the
//! layer. The nested part is attenuated by the two Fresnel transmittances and the layer's absorption
//! exp(−σₐ·d·(1/|cos θᵢ'| + 1/|cos θₒ'|)), and scaled by the compression of solid angle
//! (1/η²)·|cos θₒ|/|cos θₒ'|. Light reflected internally is discarded, as in Mitsuba 0.6.
//!
//! Sampling follows Mitsuba 0.6: the specular lobe is chosen with probability
//! F·w / (F·w + (1 − F)·(1 − w)), w = 1 / (1 + mean(exp(−2·σₐ·d))), else the nested BSDF is sampled at
//! the refracted `wi` and its `wo` refracted out. Both sides of the surface see the interface from
//! outside (Mitsuba 0.6's front- and back-side specular component).

use super::fresnel::fresnel_dielectric;
use super::TextureAt;
use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// The dielectric layer of `coating` and `roughcoating`: its relative IOR, absorption and specular
/// multiplier, and what both models derive from them.
#[derive(Clone, Debug)]
pub struct CoatingLayer {
    /// Relative IOR of the layer (int_ior / ext_ior).
    pub eta: f32,
    /// Absorption coefficient σₐ of the layer (in inverse units of `thickness`).
    pub sigma_a: Texture,
    /// Thickness of the layer.
    pub thickness: f32,
    /// Multiplier of the specular reflection (1 for physical realism).
    pub specular_reflectance: Texture,
    inv_eta_2: f32,
    specular_sampling_weight: f32,
}

impl CoatingLayer {
    /// A layer of relative IOR `eta` (positive, not 1) with absorption `sigma_a` over `thickness`.
    pub fn new(eta: f32, thickness: f32, sigma_a: Texture, specular_reflectance: Texture) -> Self {
        let avg = (sigma_a.mean() * (-2.0 * thickness)).exp();
        let avg_absorption = (avg.x + avg.y + avg.z) / 3.0;
        CoatingLayer {
            eta,
            sigma_a,
            thickness,
            specular_reflectance,
            inv_eta_2: 1.0 / (eta * eta),
            specular_sampling_weight: 1.0 / (avg_absorption + 1.0),
        }
    }

    /// The probability of sampling the interface's reflection rather than the nested BSDF, given the
    /// shares `specular` and `nested` (1 − `specular`) of the interface (Mitsuba 0.6's rule, weighed by
    /// the layer's mean absorption).
    #[inline]
    pub(super) fn prob_specular(&self, specular: f32, nested: f32) -> f32 {
        let w = self.specular_sampling_weight;
        let a = specular * w;
        let b = nested * (1.0 - w);
        if a + b > 0.0 {
            a / (a + b)
        } else {
            0.0
        }
    }

    /// Transmittance of the layer for the refracted pair.
    #[inline]
    pub(super) fn absorption(&self, ctx: &BsdfContext, wi_p: Vec3, wo_p: Vec3) -> Rgb {
        let depth = self.sigma_a.at(ctx) * self.thickness;
        if depth == Rgb::ZERO {
            return Rgb::ONE;
        }
        (-depth * (1.0 / wi_p.z.abs() + 1.0 / wo_p.z.abs())).exp()
    }

    /// The solid-angle compression (1/η²)·|cos θₒ|/|cos θₒ'| from inside the layer to outside.
    #[inline]
    pub(super) fn compression(&self, wo: Vec3, wo_p: Vec3) -> f32 {
        self.inv_eta_2 * wo.z.abs() / wo_p.z.abs()
    }
}

/// A nested BSDF under a smooth dielectric layer.
#[derive(Clone, Debug)]
pub struct Coating {
    /// The coated material (not transmissive).
    pub nested: Bsdf,
    /// The layer.
    pub layer: CoatingLayer,
}

/// Refracts `w` (either side) through an interface of relative IOR `eta` seen from outside, keeping
/// its side: the refracted direction and the Fresnel reflectance (1 under total internal reflection).
#[inline]
pub(super) fn refract_keep_side(w: Vec3, eta: f32) -> (Vec3, f32) {
    let fr = fresnel_dielectric(w.z.abs(), eta);
    let inv = 1.0 / eta;
    let z = fr.cos_theta_t.abs();
    (
        Vec3::new(inv * w.x, inv * w.y, if w.z < 0.0 { -z } else { z }),
        fr.f,
    )
}

impl Coating {
    /// `nested` under `layer`.
    pub fn new(nested: Bsdf, layer: CoatingLayer) -> Self {
        Coating { nested, layer }
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        let (wi_p, r12) = refract_keep_side(wi, self.layer.eta);
        let (wo_p, r21) = refract_keep_side(wo, self.layer.eta);
        if !(r12 < 1.0 && r21 < 1.0 && wo_p.z != 0.0) {
            return Rgb::ZERO;
        }
        let f = self.nested.eval(ctx, wi_p, wo_p);
        if f == Rgb::ZERO {
            return f;
        }
        f * self.layer.absorption(ctx, wi_p, wo_p)
            * ((1.0 - r12) * (1.0 - r21) * self.layer.compression(wo, wo_p))
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        let (wi_p, r12) = refract_keep_side(wi, self.layer.eta);
        let (wo_p, r21) = refract_keep_side(wo, self.layer.eta);
        if !(r12 < 1.0 && r21 < 1.0 && wo_p.z != 0.0) {
            return 0.0;
        }
        self.nested.pdf(ctx, wi_p, wo_p)
            * (1.0 - self.layer.prob_specular(r12, 1.0 - r12))
            * self.layer.compression(wo, wo_p)
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let (wi_p, r12) = refract_keep_side(wi, self.layer.eta);
        let ps = self.layer.prob_specular(r12, 1.0 - r12);
        if u1 < ps {
            return Some(BsdfSample {
                wo: Vec3::new(-wi.x, -wi.y, wi.z),
                pdf: ps,
                weight: self.layer.specular_reflectance.at(ctx) * (r12 / ps),
                eta: 1.0,
                delta: true,
            });
        }
        if !(r12 < 1.0) {
            return None;
        }
        let u1 = ((u1 - ps) / (1.0 - ps)).clamp(0.0, 1.0 - f32::EPSILON);
        let mut s = self.nested.sample(ctx, wi_p, u1, u2)?;
        let wo_p = s.wo;
        let (wo, r21) = refract_keep_side(wo_p, 1.0 / self.layer.eta);
        if !(r21 < 1.0 && wo_p.z != 0.0) {
            return None;
        }
        s.wo = wo;
        if s.delta {
            let scale = (1.0 - r12) * (1.0 - r21) / (1.0 - ps);
            s.weight = s.weight * self.layer.absorption(ctx, wi_p, wo_p) * scale;
            s.pdf *= 1.0 - ps;
            return Some(s);
        }
        // Recomputed from `wo` (mathematically the nested weight times the layer's factors), so that
        // weight, eval and pdf agree near the critical angle, where 1 − R is steep.
        let pdf = self.pdf(ctx, wi, wo);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        s.pdf = pdf;
        s.weight = self.eval(ctx, wi, wo) / pdf;
        Some(s)
    }

    /// Reflectance at normal incidence: the interface's plus what the nested model returns through it.
    pub(super) fn albedo(&self, ctx: &BsdfContext) -> Rgb {
        let f = fresnel_dielectric(1.0, self.layer.eta).f;
        self.layer.specular_reflectance.at(ctx) * f + self.nested.albedo(ctx) * (1.0 - f)
    }
}
