//! Linear blend of two BSDFs (Mitsuba `blendbsdf`): f = (1 − w)·f₀ + w·f₁ with a (textured) weight w.
//! Sampling picks a component with probability (1 − w, w); smooth samples report the blended pdf and
//! eval/pdf as weight, so MIS sees one consistent density.

use super::TextureAt;
use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Two BSDFs mixed by a weight texture.
#[derive(Clone, Debug)]
pub struct Blend {
    /// `[bsdf_0, bsdf_1]`.
    pub bsdfs: Box<[Bsdf; 2]>,
    /// Weight of `bsdf_1` (scalar texture, clamped to [0, 1]).
    pub weight: Texture,
}

impl Blend {
    #[inline]
    fn w(&self, ctx: &BsdfContext) -> f32 {
        let w = self.weight.at_1(ctx);
        if w.is_finite() {
            w.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        let w = self.w(ctx);
        self.bsdfs[0].eval(ctx, wi, wo) * (1.0 - w) + self.bsdfs[1].eval(ctx, wi, wo) * w
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        let w = self.w(ctx);
        self.bsdfs[0].pdf(ctx, wi, wo) * (1.0 - w) + self.bsdfs[1].pdf(ctx, wi, wo) * w
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let w = self.w(ctx);
        let (index, p, u1) = if u1 < w {
            (1, w, u1 / w)
        } else {
            (0, 1.0 - w, ((u1 - w) / (1.0 - w)).min(1.0 - f32::EPSILON))
        };
        let mut s = self.bsdfs[index].sample(ctx, wi, u1, u2)?;
        if s.delta {
            // This component's weight w_i / p_i = 1 cancels; the probability of the lobe is scaled.
            s.pdf *= p;
            return Some(s);
        }
        let pdf = self.pdf(ctx, wi, s.wo);
        if !(pdf > 0.0) {
            return None;
        }
        s.pdf = pdf;
        s.weight = self.eval(ctx, wi, s.wo) / pdf;
        Some(s)
    }
}
