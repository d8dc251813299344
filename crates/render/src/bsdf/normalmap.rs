//! Normal mapping (Mitsuba `normalmap`): the nested BSDF is evaluated in a shading frame whose normal is
//! read from an RGB texture in tangent space (n = 2·rgb − 1, with s along ∂p/∂u), as Mitsuba 3 does.
//! Directions that fall on different sides of the true and the perturbed shading normals are masked
//! out, so evaluation, sampling and pdf stay consistent (no energy from below the surface).

use super::TextureAt;
use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::frame::Frame;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A nested BSDF under a tangent-space normal map.
#[derive(Clone, Debug)]
pub struct NormalMap {
    /// The perturbed material.
    pub nested: Bsdf,
    /// Tangent-space normals encoded as rgb = (n + 1) / 2 (read raw, without sRGB decoding).
    pub normals: Texture,
}

impl NormalMap {
    /// The perturbed frame at `uv`, in the local (unperturbed) shading frame.
    #[inline]
    fn frame(&self, ctx: &BsdfContext) -> Frame {
        let n = (self.normals.at(ctx) * 2.0 - Vec3::ONE).normalize_or_zero();
        if n.z.abs() < 1e-6 || !n.is_finite() {
            return Frame::from_normal(Vec3::Z);
        }
        Frame::from_normal_tangent(n, Vec3::X)
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        eval_in_frame(&self.nested, &self.frame(ctx), ctx, wi, wo)
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        pdf_in_frame(&self.nested, &self.frame(ctx), ctx, wi, wo)
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        sample_in_frame(&self.nested, &self.frame(ctx), ctx, wi, u1, u2)
    }
}

/// `nested.eval` in the perturbed frame `f` (given in the local shading frame); zero for a `wo` on
/// different sides of the two normals. Shared by normal and bump maps.
pub(super) fn eval_in_frame(
    nested: &Bsdf,
    f: &Frame,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> Rgb {
    let wo_p = f.to_local(wo);
    if wo.z * wo_p.z <= 0.0 {
        return Rgb::ZERO;
    }
    nested.eval(ctx, f.to_local(wi), wo_p)
}

/// `nested.pdf` in the perturbed frame `f`, masked as [`eval_in_frame`].
pub(super) fn pdf_in_frame(nested: &Bsdf, f: &Frame, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
    let wo_p = f.to_local(wo);
    if wo.z * wo_p.z <= 0.0 {
        return 0.0;
    }
    nested.pdf(ctx, f.to_local(wi), wo_p)
}

/// `nested.sample` in the perturbed frame `f`; `None` for a `wo` masked as in [`eval_in_frame`].
pub(super) fn sample_in_frame(
    nested: &Bsdf,
    f: &Frame,
    ctx: &BsdfContext,
    wi: Vec3,
    u1: f32,
    u2: Vec2,
) -> Option<BsdfSample> {
    let mut s = nested.sample(ctx, f.to_local(wi), u1, u2)?;
    let wo = f.to_world(s.wo);
    if wo.z * s.wo.z <= 0.0 {
        return None;
    }
    s.wo = wo;
    Some(s)
}
