//! Opacity mask (Mitsuba `mask`): the nested BSDF scaled by an opacity o, plus a null (pass-through)
//! event that lets the light continue in a straight line with transmittance 1 − o, for cut-outs such as
//! leaves.
//!
//! The integrators do not scatter at the null event: at a hit on a shape whose BSDF is a mask they first
//! decide stochastically whether the ray passes through ([`Bsdf::pass_through`]), and shadow rays are
//! attenuated by 1 − o instead of being blocked ([`crate::scene::Scene::transmittance`]). So a
//! pass-through is no path vertex (no next-event estimation, no guiding, no Russian roulette, no depth),
//! and MIS between BSDF sampling and emitter sampling across a mask is done from the last real vertex:
//! both strategies see the same transmittance. [`Mask::sample`] still offers the null lobe as a delta
//! transmission (wo = −wi, weight (1 − o)/P) for callers that do not handle pass-through themselves
//! (e.g. a mask nested in `blendbsdf`).

use super::TextureAt;
use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A nested BSDF with an opacity texture.
#[derive(Clone, Debug)]
pub struct Mask {
    /// The BSDF of the opaque part.
    pub nested: Bsdf,
    /// Opacity o in [0, 1] per channel (1 = opaque); the selection probability is its channel mean.
    pub opacity: Texture,
}

impl Mask {
    /// The opacity at `ctx`, clamped to [0, 1] (NaN texels count as opaque).
    #[inline]
    pub fn opacity(&self, ctx: &BsdfContext) -> Rgb {
        let o = self.opacity.at(ctx);
        Rgb::new(clamp01(o.x), clamp01(o.y), clamp01(o.z))
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        self.nested.eval(ctx, wi, wo) * self.opacity(ctx)
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        self.nested.pdf(ctx, wi, wo) * mean(self.opacity(ctx))
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let o = self.opacity(ctx);
        let p_surface = mean(o);
        if u1 >= p_surface {
            return Some(BsdfSample {
                wo: -wi,
                pdf: 1.0 - p_surface,
                weight: (Rgb::ONE - o) / (1.0 - p_surface),
                eta: 1.0,
                delta: true,
            });
        }
        let u1 = (u1 / p_surface).min(1.0 - f32::EPSILON);
        let mut s = self.nested.sample(ctx, wi, u1, u2)?;
        s.pdf *= p_surface;
        s.weight *= o / p_surface;
        Some(s)
    }
}

#[inline]
fn clamp01(x: f32) -> f32 {
    if x.is_nan() {
        1.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

#[inline]
fn mean(c: Rgb) -> f32 {
    (c.x + c.y + c.z) / 3.0
}
