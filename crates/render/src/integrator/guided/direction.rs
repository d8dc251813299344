//! Choosing a guided vertex's next direction: the one-sample mixture of BSDF and guide sampling.

use crate::bsdf::{Bsdf, BsdfContext};
use crate::color::Rgb;
use crate::integrator::path_trace::Strategy;
use crate::sampler::Sampler;
use focal_guiding::{GuidingField, SamplingDistribution};

/// The guide of one vertex and the probability α of sampling it rather than the BSDF.
#[derive(Clone, Copy)]
pub(super) struct VertexGuide<'g> {
    pub(super) guide: &'g dyn GuidingField,
    pub(super) alpha: f32,
}

impl VertexGuide<'_> {
    /// The mixture pdf of direction `wo_world` and the guide's own pdf of it.
    #[inline]
    pub(super) fn mixture_pdf(
        &self,
        vertex: &SamplingDistribution,
        p_bsdf: f32,
        wo_world: glam::Vec3,
    ) -> (f32, f32) {
        let p_guide = self.guide.pdf(vertex, wo_world);
        (self.alpha * p_guide + (1.0 - self.alpha) * p_bsdf, p_guide)
    }
}

/// A sampled continuation.
pub(super) struct Step {
    pub(super) wo_world: glam::Vec3,
    /// f·cos / pdf, including the mixture's selection.
    pub(super) weight: Rgb,
    /// The pdf the direction was drawn with (the mixture's, or the BSDF's at unguided vertices; for a
    /// delta lobe the BSDF branch's probability, used only for MIS against nothing).
    pub(super) pdf: f32,
    /// The BSDF's own pdf of the direction.
    pub(super) bsdf_pdf: f32,
    /// The guide's own pdf of the direction (0 at unguided vertices).
    pub(super) guide_pdf: f32,
    pub(super) eta: f32,
    pub(super) strategy: Strategy,
}

impl Step {
    pub(super) fn delta(&self) -> bool {
        self.strategy == Strategy::Delta
    }
}

/// Samples the next direction at a vertex; `None` ends the path.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn sample_direction(
    bsdf: &Bsdf,
    guide: Option<VertexGuide<'_>>,
    vertex: &SamplingDistribution,
    ctx: &BsdfContext,
    si: &crate::geometry::SurfaceInteraction,
    wi: glam::Vec3,
    sampler: &mut Sampler,
) -> Option<Step> {
    let u_select = sampler.next_1d();
    let u1 = sampler.next_1d();
    let u2 = sampler.next_2d();
    let Some(guide) = guide else {
        let bs = bsdf.sample(ctx, wi, u1, u2)?;
        return Some(Step {
            wo_world: si.to_world(bs.wo),
            weight: bs.weight,
            pdf: bs.pdf,
            bsdf_pdf: bs.pdf,
            guide_pdf: 0.0,
            eta: bs.eta,
            strategy: if bs.delta {
                Strategy::Delta
            } else {
                Strategy::Bsdf
            },
        });
    };
    let alpha = guide.alpha;
    if u_select >= alpha {
        // BSDF branch.
        let bs = bsdf.sample(ctx, wi, u1, u2)?;
        let wo_world = si.to_world(bs.wo);
        if bs.delta {
            return Some(Step {
                wo_world,
                weight: bs.weight / (1.0 - alpha),
                pdf: (1.0 - alpha) * bs.pdf,
                bsdf_pdf: bs.pdf,
                guide_pdf: 0.0,
                eta: bs.eta,
                strategy: Strategy::Delta,
            });
        }
        let f = bsdf.eval(ctx, wi, bs.wo);
        let p_bsdf = bsdf.pdf(ctx, wi, bs.wo);
        let (pdf, guide_pdf) = guide.mixture_pdf(vertex, p_bsdf, wo_world);
        if !(pdf > 0.0) || f == Rgb::ZERO {
            return None;
        }
        Some(Step {
            wo_world,
            weight: f / pdf,
            pdf,
            bsdf_pdf: p_bsdf,
            guide_pdf,
            eta: bs.eta,
            strategy: Strategy::Bsdf,
        })
    } else {
        // Guide branch: the rescaled selection number is uniform again and drives the guide's choice.
        let u0 = (u_select / alpha).min(1.0 - f32::EPSILON / 2.0);
        let gs = guide.guide.sample(vertex, [u0, u2.x, u2.y])?;
        let wo = si.to_local(gs.direction);
        let f = bsdf.eval(ctx, wi, wo);
        if f == Rgb::ZERO {
            // Rath: a guided direction the BSDF does not scatter into ends the path (no retry).
            return None;
        }
        let p_bsdf = bsdf.pdf(ctx, wi, wo);
        let pdf = alpha * gs.pdf + (1.0 - alpha) * p_bsdf;
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        let eta = if wo.z * wi.z < 0.0 {
            transmission_eta(bsdf, wi)
        } else {
            1.0
        };
        Some(Step {
            wo_world: gs.direction,
            weight: f / pdf,
            pdf,
            bsdf_pdf: p_bsdf,
            guide_pdf: gs.pdf,
            eta,
            strategy: Strategy::Guide,
        })
    }
}

/// The relative index of refraction for a guided transmission (only Russian roulette reads it, and only
/// through eta², so an approximation is harmless; rough dielectrics are the only non-delta transmitters).
fn transmission_eta(bsdf: &Bsdf, wi: glam::Vec3) -> f32 {
    match bsdf {
        Bsdf::RoughDielectric(b) => {
            if wi.z > 0.0 {
                b.eta
            } else {
                1.0 / b.eta
            }
        }
        _ => 1.0,
    }
}
