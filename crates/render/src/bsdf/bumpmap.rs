//! Bump mapping (Mitsuba `bumpmap`): the nested BSDF is evaluated in a shading frame perturbed by a
//! height field h(u, v), as Mitsuba 3's bumpmap.cpp: ∂p/∂u' = ∂p/∂u + n·(s·∂h/∂u − n·∂p/∂u) (and the same
//! for v), n' = normalize(∂p/∂u' × ∂p/∂v') turned to the side of the unperturbed normal, s' = ∂p/∂u
//! made orthogonal to n'. The height's gradient is the analytic derivative of its bilinear
//! interpolation (Mitsuba 3's `eval_1_grad`); the surface's ∂p/∂u, ∂p/∂v come with the query
//! ([`BsdfContext::dp_du`]). Masking of directions between the two normals is the normal map's.
//!
//! With `use_shadowing_function` (Mitsuba 3's default; Mitsuba 0.6 had none) the response is
//! attenuated by Estevez et al.'s microfacet shadowing term for bump maps ("A Microfacet-Based
//! Shadowing Function to Solve the Bump Terminator Problem", Ray Tracing Gems 2019), as Mitsuba 3 does:
//! in eval and in the sample weight, not in the pdf.
//!
//! Differences from Mitsuba 3, both invisible for isotropic models on ordinary meshes: n' is turned
//! towards the shading normal (Mitsuba: the geometric normal), and s' is orthogonalised in the local
//! frame (Mitsuba mixes a world-space ∂p/∂u with the local n' there).

use super::normalmap::{eval_in_frame, pdf_in_frame, sample_in_frame};
use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use crate::frame::Frame;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A nested BSDF under a height-field bump map.
#[derive(Clone, Debug)]
pub struct BumpMap {
    /// The perturbed material.
    pub nested: Bsdf,
    /// The height field (scalar: luminance of colour textures).
    pub height: Texture,
    /// Multiplier of the height gradient (Mitsuba 3 `scale`, default 1).
    pub scale: f32,
    /// Attenuate by the bump-terminator shadowing term (Mitsuba 3 `use_shadowing_function`).
    pub shadowing: bool,
}

/// Estevez et al.'s shadowing term for a perturbed normal `n` (local frame) and direction `wo`:
/// α² = clamp(tan²θ(n)/8, 0, 1), G = 2 / (1 + √(1 + α²·tan²θ(wo))).
#[inline]
pub fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let cos_d = n.z.abs().min(1.0);
    let tan2_d = (1.0 - cos_d * cos_d) / (cos_d * cos_d);
    let alpha2 = (0.125 * tan2_d).clamp(0.0, 1.0);
    let cos_o = wo.z.abs().max(1e-6);
    let tan2_o = (1.0 - cos_o * cos_o) / (cos_o * cos_o);
    2.0 / (1.0 + (1.0 + alpha2 * tan2_o).sqrt())
}

impl BumpMap {
    /// The perturbed frame at the query point, in the local (unperturbed) shading frame; the
    /// unperturbed frame where the surface derivatives are unknown or degenerate.
    #[inline]
    pub fn frame(&self, ctx: &BsdfContext) -> Frame {
        if ctx.dp_du == Vec3::ZERO || ctx.dp_dv == Vec3::ZERO {
            return Frame::from_normal(Vec3::Z);
        }
        let g = self.height.eval_1_grad(ctx.uv) * self.scale;
        // In the local frame n = +Z, so adding n·(g − n·∂p/∂u) replaces the z component by g.
        let du = Vec3::new(ctx.dp_du.x, ctx.dp_du.y, g.x);
        let dv = Vec3::new(ctx.dp_dv.x, ctx.dp_dv.y, g.y);
        let n = du.cross(dv).normalize_or_zero();
        if n.z == 0.0 || !n.is_finite() {
            return Frame::from_normal(Vec3::Z);
        }
        let n = if n.z < 0.0 { -n } else { n };
        Frame::from_normal_tangent(n, ctx.dp_du)
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        let f = self.frame(ctx);
        let value = eval_in_frame(&self.nested, &f, ctx, wi, wo);
        if self.shadowing {
            value * shadow_terminator(f.n, wo)
        } else {
            value
        }
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
        let f = self.frame(ctx);
        let mut s = sample_in_frame(&self.nested, &f, ctx, wi, u1, u2)?;
        if self.shadowing {
            s.weight *= shadow_terminator(f.n, s.wo);
        }
        Some(s)
    }
}
