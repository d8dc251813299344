//! Light transport estimators. A coarse extension point: the render loop drives any [`Integrator`].

mod guided;
mod path;
pub mod path_trace;

pub use guided::{GuidedPathIntegrator, GuidedSettings, Roulette, GLOSSY_ROUGHNESS};
pub use path::{PathIntegrator, PathSettings};

use crate::bsdf::{Bsdf, BsdfContext};
use crate::color::Rgb;
use crate::geometry::SurfaceInteraction;
use crate::ray::{offset_ray_origin, CameraRay, Ray};
use crate::sampler::Sampler;
use crate::scene::{Scene, MAX_PASS_THROUGH};
use glam::Vec3;

/// Auxiliary per-sample outputs recorded at the first camera hit.
#[derive(Clone, Copy, Debug, Default)]
pub struct FirstHitAovs {
    /// Reflectance estimate of the first surface hit.
    pub albedo: Rgb,
    /// Shading normal at the first hit (world space).
    pub normal: Vec3,
    /// Distance along the camera ray to the first hit (0 if none).
    pub depth: f32,
}

/// Estimates the radiance arriving along camera rays.
pub trait Integrator: Send + Sync {
    /// One-sample estimate of the radiance along `ray`; fills `aovs` at the first hit. The ray's
    /// differential, if any, gives MIP-mapped textures their footprint at the first hit; later
    /// bounces read the finest level (as Mitsuba 0.6). (Recording training data is the guided
    /// integrator's own [`GuidedPathIntegrator::li_recording`].)
    fn li(
        &self,
        scene: &Scene,
        ray: &CameraRay,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
    ) -> Rgb;
}

/// The BSDF query at a hit: its uv and, while the path is still on its camera ray (`first_hit`, also
/// after pass-throughs, which keep the ray's direction), the pixel footprint of `differential`.
#[inline]
pub(crate) fn bsdf_context(
    scene: &Scene,
    si: &SurfaceInteraction,
    differential: Option<&crate::ray::RayDifferential>,
    first_hit: bool,
) -> BsdfContext {
    let mut ctx = BsdfContext::at_uv(si.uv);
    ctx.dp_du = si.to_local(si.dp_du);
    ctx.dp_dv = si.to_local(si.dp_dv);
    if let (true, Some(d)) = (first_hit, differential) {
        ctx.footprint = scene.uv_footprint(si, d);
    }
    ctx
}

/// The power heuristic (β = 2) weight of a strategy with density `a` against one with density `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// Next-event estimation at a surface hit: picks an emitter, samples a point on it, tests visibility and
/// returns f·cos·Le/pdf, MIS-weighted by the power heuristic against `direction_pdf(wo_local, wo_world)`,
/// the density with which the integrator's own direction sampling would have produced that direction.
/// Zero for BSDFs without a smooth component. Draws four sampler dimensions when it runs.
#[inline]
pub(crate) fn next_event_estimate(
    scene: &Scene,
    si: &SurfaceInteraction,
    bsdf: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    sampler: &mut Sampler,
    direction_pdf: impl FnOnce(Vec3, Vec3) -> f32,
) -> Rgb {
    if !bsdf.has_smooth() {
        return Rgb::ZERO;
    }
    let u1 = sampler.next_1d();
    let u2 = sampler.next_1d();
    let u = sampler.next_2d();
    let Some((_, es)) = scene.sample_emitter_direction(si.p, u1, u2, u) else {
        return Rgb::ZERO;
    };
    let wo = si.to_local(es.wi);
    let f = bsdf.eval(ctx, wi, wo);
    if f == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let o = offset_ray_origin(si.p, si.ng, es.wi);
    let t_max = if es.dist.is_finite() {
        (es.dist * (1.0 - 1e-4)).max(0.0)
    } else {
        f32::INFINITY
    };
    let transmittance = scene.transmittance(&Ray::segment(o, es.wi, t_max));
    if transmittance == Rgb::ZERO {
        return Rgb::ZERO;
    }
    let mis = if es.delta {
        1.0
    } else {
        power_heuristic(es.pdf, direction_pdf(wo, es.wi))
    };
    f * transmittance * es.weight * mis
}

/// The run of consecutive pass-throughs (masks) since a path's last vertex: how many, and the distance
/// they covered (training segments and the depth AOV run from vertex to vertex, through any masks).
#[derive(Default)]
pub(crate) struct PassThroughRun {
    passes: u32,
    travelled: f32,
}

impl PassThroughRun {
    /// Records a pass-through of `ray` at `si` with the path's `throughput` after it; returns
    /// the continued ray, or `None` if the path ends (no throughput left, or [`MAX_PASS_THROUGH`] in a
    /// row).
    pub(crate) fn pass(
        &mut self,
        ray: &Ray,
        si: &SurfaceInteraction,
        throughput: Rgb,
    ) -> Option<Ray> {
        self.passes += 1;
        self.travelled += si.t;
        if self.passes >= MAX_PASS_THROUGH || !(throughput.max_element() > 0.0) {
            return None;
        }
        Some(Ray::new(offset_ray_origin(si.p, si.ng, ray.d), ray.d))
    }

    /// At a vertex reached at distance `t` after the run: the distance from the last vertex, and the run
    /// starts afresh.
    pub(crate) fn end(&mut self, t: f32) -> f32 {
        let d = self.travelled + t;
        *self = Self::default();
        d
    }
}

/// The stochastic pass-through decision at a hit (see [`Bsdf::pass_through`]): `None` if the ray passes
/// straight through a `mask` (the throughput is updated and the hit is no vertex), else the BSDF that
/// scatters there (the mask's opaque part, with the throughput reweighted by o/mean(o)). Draws one
/// sampler dimension at masks only.
#[inline]
pub(crate) fn resolve_pass_through<'a>(
    bsdf: &'a Bsdf,
    ctx: &BsdfContext,
    sampler: &mut Sampler,
    throughput: &mut Rgb,
) -> Option<&'a Bsdf> {
    let Some(t) = bsdf.pass_through(ctx) else {
        return Some(bsdf);
    };
    let p = t.element_sum() / 3.0;
    if sampler.next_1d() < p {
        *throughput *= t / p;
        None
    } else {
        *throughput *= (Rgb::ONE - t) / (1.0 - p);
        Some(bsdf.opaque_part())
    }
}
