//! Two-sided adapter (Mitsuba `twosided`): makes one-sided reflection models respond on both sides by
//! mirroring the directions through the surface when `wi` is on the back side; with two nested BSDFs
//! the second one is used for the back side.

use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use glam::{Vec2, Vec3};

/// Front and back BSDFs (the same model twice when only one was given).
#[derive(Clone, Debug)]
pub struct TwoSided {
    /// `[front, back]`; both are reflection-only models. Shared, so that cloning is cheap: a `twosided`
    /// with one nested BSDF holds it twice, and nested `twosided`s would otherwise double the tree at
    /// every level (60 levels took all memory).
    pub sides: std::sync::Arc<[Bsdf; 2]>,
}

#[inline]
fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

impl TwoSided {
    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z > 0.0 {
            self.sides[0].eval(ctx, wi, wo)
        } else {
            self.sides[1].eval(ctx, flip(wi), flip(wo))
        }
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z > 0.0 {
            self.sides[0].pdf(ctx, wi, wo)
        } else {
            self.sides[1].pdf(ctx, flip(wi), flip(wo))
        }
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z > 0.0 {
            self.sides[0].sample(ctx, wi, u1, u2)
        } else {
            let mut s = self.sides[1].sample(ctx, flip(wi), u1, u2)?;
            s.wo = flip(s.wo);
            Some(s)
        }
    }
}
