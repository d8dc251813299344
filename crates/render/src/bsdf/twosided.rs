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
    /// The sides' lobe properties, combined once here: asking the sides at every query walks both of
    /// them, and through nested `twosided`s, each holding its one child twice, that took time
    /// doubling with every level.
    pub(super) lobes: SideLobes,
}

/// What [`Bsdf::has_smooth`], [`Bsdf::has_delta`], [`Bsdf::has_transmission`] and
/// [`Bsdf::min_roughness`] answer for a two-sided BSDF.
#[derive(Clone, Copy, Debug)]
pub(super) struct SideLobes {
    pub(super) smooth: bool,
    pub(super) delta: bool,
    pub(super) transmission: bool,
    pub(super) min_roughness: f32,
}

#[inline]
fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

impl TwoSided {
    /// The two-sided BSDF with `front` and `back` (the same model twice for one nested BSDF).
    pub fn new(front: Bsdf, back: Bsdf) -> Self {
        let lobes = SideLobes {
            smooth: front.has_smooth() || back.has_smooth(),
            delta: front.has_delta() || back.has_delta(),
            transmission: front.has_transmission() || back.has_transmission(),
            min_roughness: front.min_roughness().min(back.min_roughness()),
        };
        TwoSided {
            sides: std::sync::Arc::new([front, back]),
            lobes,
        }
    }

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
