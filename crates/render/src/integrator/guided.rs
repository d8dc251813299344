//! Guided unidirectional path tracing (focal path guiding, Rath et al. 2023 §5): at every non-delta vertex
//! a one-sample mixture of BSDF sampling and a learned [`GuidingField`] proposes the next direction,
//! next-event estimation is MIS-weighted against the mixture pdf, and the path's segments are recorded as
//! training data for the next iteration.

use super::path_trace::{LightEvent, PathObserver, PathTrace, Strategy, TracedVertex};
use super::{
    bsdf_context, next_event_estimate, power_heuristic, resolve_pass_through, FirstHitAovs,
    Integrator, PassThroughRun, PathSettings,
};
use crate::bsdf::{Bsdf, BsdfContext};
use crate::color::Rgb;
use crate::ray::{offset_ray_origin, CameraRay, Ray};
use crate::sampler::Sampler;
use crate::scene::Scene;
use focal_guiding::{
    GuidingField, SamplingDistribution, TrainingSegment, EXPLORATION_FRACTION,
    EXPLORATION_PROBABILITY,
};
use std::cell::Cell;

/// Roughness below which a path vertex counts as glossy (Ruppert et al. 2020, as the focal-guiding code):
/// a glossy endpoint can form a virtual image, so the whole line through it is a focal candidate.
pub const GLOSSY_ROUGHNESS: f32 = 0.3;

/// Cosine of the largest angle between the direction a path enters a run of glass vertices with and the
/// direction it leaves them with for the glass to count as a window rather than a lens: behind a pane
/// the light source is where the straight line through the glass points, behind a ball it is not.
pub const STRAIGHT_THROUGH_COS: f32 = 0.985;

/// How a guided path decides to terminate.
///
/// Mitsuba's throughput-based roulette kills exactly the low-throughput prefixes that guiding makes
/// worthwhile: a guided direction through a pinhole has a tiny weight f·cos/p_mix with a huge radiance
/// behind it, so it is killed with high probability, which undoes the gain (Rath et al.'s README; they use
/// no roulette at all). But with no roulette, a closed room under an unlimited `max_depth` has paths of
/// thousands of bounces. The default therefore survives with the product of the BSDF *albedos* along the
/// path instead of the throughput: it terminates paths as fast as the path tracer does in expectation (the
/// mean BSDF-sampling weight is the albedo), whatever the guide chose. Unguided paths (the first
/// iteration, or a render that fell back to path tracing) have no guided prefixes to protect and use
/// the throughput roulette instead: it puts the samples where the throughput is
/// (docs/experiments/2026-12-01-unguided-roulette.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Roulette {
    /// No roulette (Rath et al.; set a `max_depth`).
    Off,
    /// Mitsuba's: survival min(0.95, max throughput · η²) from `rr_depth`.
    Throughput,
    /// Survival min(0.95, Π albedo · η² / Π earlier survivals) from `rr_depth` (default): as Mitsuba's,
    /// with the albedo product in place of the throughput.
    Albedo,
}

impl Roulette {
    /// Parses `off`, `throughput` or `albedo`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "off" | "none" => Ok(Roulette::Off),
            "throughput" | "mitsuba" => Ok(Roulette::Throughput),
            "albedo" => Ok(Roulette::Albedo),
            other => Err(format!(
                "unknown Russian roulette mode '{other}' (off, throughput or albedo)"
            )),
        }
    }
}

/// Settings of the guided path tracer.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct GuidedSettings {
    /// Depth, roulette start depth and emitter visibility, with the path tracer's meanings (its
    /// `russian_roulette` flag is ignored: see `roulette`).
    pub path: PathSettings,
    /// The Russian roulette.
    pub roulette: Roulette,
    /// Also train on segments that escaped the scene, as half-lines clipped to the scene box (light
    /// through a window from the sky). Rath et al. drop them; both guides benefit alike.
    pub train_escaped: bool,
    /// Probability of sampling the guide rather than the BSDF at a guided vertex (Rath: 0.5), for
    /// guides that ask for none (the octree) or when `learned_selection` is off.
    pub guide_fraction: f32,
    /// Use the guide's own selection probability where it has one
    /// ([`GuidingField::selection_probability`]: the GMM's fixed or learned fraction) instead of
    /// `guide_fraction`; off when the user gave a fraction.
    pub learned_selection: bool,
    /// Restrict guide sampling to the shading hemisphere at opaque (non-transmissive) BSDFs, if the
    /// guide supports it (the GMM's truncated sampling); the octree ignores the hint.
    pub hemisphere_hint: bool,
    /// Split a path whose throughput the one-sample mixture has inflated beyond twice the product of
    /// the BSDF albedos (with the roulette's survivals, as `Roulette::Albedo` keeps it) into copies
    /// carrying twice it each (fewer where the caps of four per vertex and 64 per camera sample bind;
    /// a random count of copies with that expectation), in renders that record no training segments;
    /// only with albedo roulette. Where the guide does not cover the
    /// directions the BSDF samples, every BSDF-branch vertex multiplies the weight by up to 1/(1 − α)
    /// (4 at α = 0.75) at probability 1 − α, so the second moment of a diffuse chain grows by that
    /// factor per vertex: the brightest samples of the camera obscura, the lens focus and the door gap
    /// were such chains of 5–10 vertices. Splitting averages their continuations instead (a weight
    /// window as Vorba and Křivánek's, with the albedo product standing in for the learned adjoint;
    /// docs/experiments/2026-12-03-path-splitting.md).
    pub split: bool,
}

impl Default for GuidedSettings {
    fn default() -> Self {
        GuidedSettings {
            path: PathSettings::default(),
            roulette: Roulette::Albedo,
            train_escaped: true,
            guide_fraction: 0.5,
            learned_selection: true,
            hemisphere_hint: true,
            split: true,
        }
    }
}

/// The guided path tracer for one iteration: `guide` is `None` in the unguided first iteration (the
/// estimator is then exactly the path tracer without Russian roulette); `record` collects training
/// segments.
pub struct GuidedPathIntegrator<'g> {
    /// Settings.
    pub settings: GuidedSettings,
    /// The guide of this iteration (read-only while rendering).
    pub guide: Option<&'g dyn GuidingField>,
    /// Record training segments.
    pub record: bool,
}

/// The buffers a path needs, kept per thread instead of allocated per sample: with a large mixture the
/// guide's per-vertex terms are several KiB, and allocating and zeroing them for every path took about
/// 7 % of a guided render.
#[derive(Default)]
struct PathScratch {
    pending: Vec<PendingSegment>,
    vertex: SamplingDistribution,
    branches: Vec<Branch>,
}

/// A split-off copy of a path, waiting to be continued from its next ray.
#[derive(Clone, Copy)]
struct Branch {
    ray: Ray,
    throughput: Rgb,
    eta: f32,
    albedo: f32,
    depth: u32,
    prev_p: glam::Vec3,
    prev_pdf: f32,
    prev_delta: bool,
}

/// A path is split where its throughput exceeds this many times the albedo product, into copies that
/// each carry this many times it (see [`GuidedSettings::split`]).
const SPLIT_AT: f32 = 2.0;
/// The most copies one split makes, in expectation.
const MAX_SPLIT: f32 = 4.0;
/// The most split-off copies one camera sample may make in all.
const MAX_BRANCHES: usize = 64;

thread_local! {
    static SCRATCH: Cell<PathScratch> = Cell::new(PathScratch::default());
}

/// A recorded segment whose contribution is not known until the path ends.
#[derive(Clone, Copy)]
struct PendingSegment {
    segment: TrainingSegment,
    /// The path's estimate just before the segment was sampled: everything added later flows through it.
    result_before: Rgb,
    /// The endpoint is glossy glass and the path has not yet left the glass: whether the straight line
    /// through it points where the light came from is not known yet.
    in_glass: bool,
    /// The path refracted (η ≠ 1) since this segment's endpoint.
    refracted: bool,
}

/// Settles `refracting_endpoint` for the segments `pending[from..]` that ended on glass, now that the path
/// has left the glass in direction `d_out` (to a non-glass vertex, or out of the scene): the path bent
/// by refraction if it refracted on the way and left at more than arccos([`STRAIGHT_THROUGH_COS`]) from
/// the segment's direction. Reflection off glass keeps the line (a mirror's virtual image).
fn leave_glass(pending: &mut [PendingSegment], from: usize, d_out: glam::Vec3) {
    for p in pending[from..].iter_mut().filter(|p| p.in_glass) {
        p.in_glass = false;
        p.segment.refracting_endpoint =
            p.refracted && p.segment.direction.dot(d_out) < STRAIGHT_THROUGH_COS;
    }
}

/// The guide of one vertex and the probability α of sampling it rather than the BSDF.
#[derive(Clone, Copy)]
struct VertexGuide<'g> {
    guide: &'g dyn GuidingField,
    alpha: f32,
}

impl VertexGuide<'_> {
    /// The mixture pdf of direction `wo_world` and the guide's own pdf of it.
    #[inline]
    fn mixture_pdf(
        &self,
        vertex: &SamplingDistribution,
        p_bsdf: f32,
        wo_world: glam::Vec3,
    ) -> (f32, f32) {
        let p_guide = self.guide.pdf(vertex, wo_world);
        (self.alpha * p_guide + (1.0 - self.alpha) * p_bsdf, p_guide)
    }
}

impl GuidedPathIntegrator<'_> {
    /// The guide of a vertex at `x` with a smooth BSDF, if it is sampled there: the learned selection
    /// probability (or the fixed fraction); where that is 0, the guide only at a random exploring share
    /// of the vertices (one uniform number is drawn only then).
    #[inline]
    fn vertex_guide(
        &self,
        x: glam::Vec3,
        glossy: bool,
        sampler: &mut Sampler,
    ) -> Option<VertexGuide<'_>> {
        let guide = self.guide?;
        let learned = if self.settings.learned_selection {
            guide.selection_probability(x, glossy)
        } else {
            None
        };
        let mut alpha = learned.unwrap_or(self.settings.guide_fraction);
        if alpha <= 0.0 && learned.is_some() && sampler.next_1d() < EXPLORATION_PROBABILITY {
            alpha = EXPLORATION_FRACTION;
        }
        (alpha > 0.0).then_some(VertexGuide { guide, alpha })
    }
}

impl Integrator for GuidedPathIntegrator<'_> {
    fn li(
        &self,
        scene: &Scene,
        ray: &CameraRay,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
        training: &mut Vec<TrainingSegment>,
    ) -> Rgb {
        self.trace_path(scene, ray, sampler, aovs, training, &mut ())
    }
}

impl GuidedPathIntegrator<'_> {
    /// [`Integrator::li`] that also records the path's decisions and light into `trace` (cleared
    /// first), for finding where fireflies come from: the same estimate, sample for sample.
    pub fn li_traced(
        &self,
        scene: &Scene,
        ray: &CameraRay,
        sampler: &mut Sampler,
        trace: &mut PathTrace,
    ) -> Rgb {
        trace.vertices.clear();
        trace.lights.clear();
        trace.branches = 0;
        let mut aovs = FirstHitAovs::default();
        let mut training = Vec::new();
        self.trace_path(scene, ray, sampler, &mut aovs, &mut training, trace)
    }

    fn trace_path<O: PathObserver>(
        &self,
        scene: &Scene,
        camera_ray: &CameraRay,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
        training: &mut Vec<TrainingSegment>,
        observer: &mut O,
    ) -> Rgb {
        let mut ray = camera_ray.ray;
        let s = &self.settings.path;
        if s.max_depth == 0 {
            return Rgb::ZERO;
        }
        let mut result = Rgb::ZERO;
        let mut throughput = Rgb::ONE;
        let mut eta = 1.0f32;
        let mut albedo = 1.0f32;
        let mut depth: u32 = 0;
        let mut prev_p = ray.o;
        // pdf of the last sampled direction (the mixture's at guided vertices), for emitter-hit MIS.
        let mut prev_pdf = 1.0f32;
        let mut prev_delta = true;
        let PathScratch {
            mut pending,
            mut vertex,
            mut branches,
        } = SCRATCH.with(Cell::take);
        pending.clear();
        branches.clear();
        let split = self.settings.split && !self.record;
        let mut made = 0usize;
        let mut run = PassThroughRun::default();
        // The first pending segment that may still be inside a run of glass vertices.
        let mut glass_from: Option<usize> = None;
        let roulette = match (self.settings.roulette, self.guide) {
            (Roulette::Albedo, None) => Roulette::Throughput,
            (r, _) => r,
        };

        'paths: loop {
            loop {
                let si = scene.intersect(&ray);
                let visible = !(s.hide_emitters && depth == 0);
                let Some(si) = si else {
                    if let Some(env) = scene.environment {
                        if visible {
                            let le = scene.emitters[env as usize].eval_environment(ray.d);
                            let (mis, nee_pdf) = mis_against_nee(prev_delta, prev_pdf, || {
                                scene.pdf_emitter_direction_env(ray.d)
                            });
                            let emitted = throughput * le * mis;
                            result += emitted;
                            note_emission(&mut pending, emitted, nee_pdf);
                            observer.light(
                                depth,
                                LightEvent::Environment,
                                emitted.element_sum() / 3.0,
                            );
                        }
                    }
                    if let Some(from) = glass_from.take() {
                        leave_glass(&mut pending, from, ray.d);
                    }
                    if self.settings.train_escaped {
                        if let Some(last) = pending.last_mut() {
                            if last.segment.distance < 0.0 {
                                last.segment.distance = f32::INFINITY;
                            }
                        }
                    }
                    break;
                };
                if let Some(e) = scene.shapes[si.shape as usize].emitter {
                    let le = scene.emitters[e as usize].eval_area(si.to_local(-ray.d).z);
                    if visible && le != Rgb::ZERO {
                        let (mis, nee_pdf) = mis_against_nee(prev_delta, prev_pdf, || {
                            scene.pdf_emitter_direction_area(prev_p, &si)
                        });
                        let emitted = throughput * le * mis;
                        result += emitted;
                        note_emission(&mut pending, emitted, nee_pdf);
                        observer.light(depth, LightEvent::EmitterHit, emitted.element_sum() / 3.0);
                    }
                }
                let ctx = bsdf_context(scene, &si, camera_ray.differential.as_ref(), depth == 0);
                // A pass-through is no vertex: no guiding, no training vertex, no depth; the MIS state of
                // the last vertex stays.
                let Some(bsdf) = resolve_pass_through(
                    &scene.bsdfs[scene.shapes[si.shape as usize].bsdf as usize],
                    &ctx,
                    sampler,
                    &mut throughput,
                ) else {
                    match run.pass(&ray, &si, throughput) {
                        Some(next) => ray = next,
                        None => break,
                    }
                    continue;
                };
                let distance = run.end(si.t);
                let glossy = bsdf.min_roughness() < GLOSSY_ROUGHNESS;
                let glass = glossy && bsdf.has_transmission();
                if !glass {
                    if let Some(from) = glass_from.take() {
                        leave_glass(&mut pending, from, ray.d);
                    }
                }
                let open = pending.len();
                if let Some(last) = pending.last_mut() {
                    if last.segment.distance < 0.0 {
                        last.segment.distance = distance;
                        last.segment.glossy_endpoint = glossy;
                        if glass {
                            last.in_glass = true;
                            glass_from.get_or_insert(open - 1);
                        }
                    }
                }
                if depth == 0 {
                    aovs.albedo = bsdf.albedo(&ctx);
                    aovs.normal = si.sh_frame.n;
                    aovs.depth = distance;
                }
                if depth.saturating_add(1) >= s.max_depth {
                    break;
                }

                let wi = si.to_local(-ray.d);
                let guide = if bsdf.has_smooth() {
                    self.vertex_guide(si.p, glossy, sampler)
                } else {
                    None
                };
                // The hemisphere the BSDF reflects into (shading normal on the incident side), for guides that
                // can truncate their sampling to it.
                let hint = (self.settings.hemisphere_hint && !bsdf.has_transmission())
                    .then(|| si.sh_frame.n * wi.z.signum());
                if let Some(g) = guide {
                    g.guide.init(&mut vertex, si.p, hint);
                }

                // Next-event estimation, MIS-weighted against the full sampling mixture.
                let direct = throughput
                    * next_event_estimate(scene, &si, bsdf, &ctx, wi, sampler, |wo, wo_world| {
                        let p_bsdf = bsdf.pdf(&ctx, wi, wo);
                        match guide {
                            Some(g) => g.mixture_pdf(&vertex, p_bsdf, wo_world).0,
                            None => p_bsdf,
                        }
                    });
                result += direct;
                if direct != Rgb::ZERO {
                    observer.light(depth, LightEvent::NextEvent, direct.element_sum() / 3.0);
                }

                // Direction sampling: BSDF, or the one-sample BSDF/guide mixture.
                let Some(step) = sample_direction(bsdf, guide, &vertex, &ctx, &si, wi, sampler)
                else {
                    break;
                };
                if let Some(from) = glass_from {
                    if step.eta != 1.0 {
                        pending[from..].iter_mut().for_each(|p| p.refracted = true);
                    }
                }
                if self.record && !step.delta() {
                    pending.push(PendingSegment {
                        segment: TrainingSegment {
                            origin: si.p,
                            direction: step.wo_world,
                            distance: -1.0,
                            weight: 0.0,
                            pdf: step.pdf,
                            bsdf_pdf: step.bsdf_pdf,
                            guide_pdf: step.guide_pdf,
                            guide_fraction: guide.map_or(0.0, |g| g.alpha),
                            glossy_endpoint: false,
                            glossy_origin: glossy,
                            refracting_endpoint: false,
                            emitted: 0.0,
                            emitter_pdf: 0.0,
                            pixel_weight: 1.0,
                        },
                        result_before: result,
                        in_glass: false,
                        refracted: false,
                    });
                }
                throughput *= step.weight;
                observer.vertex(TracedVertex {
                    depth,
                    bsdf: bsdf.plugin_name(),
                    glossy,
                    guide_fraction: guide.map_or(0.0, |g| g.alpha),
                    strategy: step.strategy,
                    bsdf_pdf: step.bsdf_pdf,
                    guide_pdf: step.guide_pdf,
                    pdf: step.pdf,
                    weight: step.weight.max_element(),
                    throughput: throughput.max_element(),
                    survival: 1.0,
                    split: 1.0,
                    branch: 0,
                });
                eta *= step.eta;
                prev_p = si.p;
                prev_pdf = step.pdf;
                prev_delta = step.delta();
                depth += 1;

                let tmax = throughput.max_element();
                if !(tmax > 0.0) || !tmax.is_finite() {
                    break;
                }
                if roulette == Roulette::Albedo {
                    albedo *= bsdf.albedo(&ctx).max_element();
                }
                let survival = match roulette {
                    Roulette::Off => 1.0,
                    Roulette::Throughput => tmax,
                    Roulette::Albedo => albedo,
                };
                if roulette != Roulette::Off && depth >= s.rr_depth {
                    let q = (survival * eta * eta).min(0.95);
                    observer.survival(q);
                    if sampler.next_1d() >= q {
                        break;
                    }
                    throughput /= q;
                    // As the throughput, the albedo product carries the survivals so far: the next vertex
                    // then survives by its own albedo, and reaching depth k has the probability of the
                    // albedo product. Without it every later roulette divided by the whole product
                    // again, and the boosts compounded
                    // (docs/experiments/2026-12-03-albedo-roulette-fix.md).
                    albedo /= q;
                }
                ray = Ray::new(offset_ray_origin(si.p, si.ng, step.wo_world), step.wo_world);
                if split && roulette == Roulette::Albedo {
                    let ratio = throughput.max_element() / albedo;
                    if ratio > SPLIT_AT {
                        let target = (ratio / SPLIT_AT).min(MAX_SPLIT);
                        let extra = target.floor() as usize - 1
                            + usize::from(sampler.next_1d() < target.fract());
                        if made + extra <= MAX_BRANCHES {
                            made += extra;
                            throughput /= target;
                            observer.split(target);
                            for _ in 0..extra {
                                branches.push(Branch {
                                    ray,
                                    throughput,
                                    eta,
                                    albedo,
                                    depth,
                                    prev_p,
                                    prev_pdf,
                                    prev_delta,
                                });
                            }
                        }
                    }
                }
            }
            let Some(b) = branches.pop() else {
                break 'paths;
            };
            observer.resume();
            Branch {
                ray,
                throughput,
                eta,
                albedo,
                depth,
                prev_p,
                prev_pdf,
                prev_delta,
            } = b;
            run = PassThroughRun::default();
            glass_from = None;
        }

        if self.record {
            for p in &pending {
                // Segments whose ray escaped or was never traced carry no endpoint.
                if p.segment.distance < 0.0 {
                    continue;
                }
                let c = (result - p.result_before).element_sum() / 3.0;
                if c > 0.0 && c.is_finite() {
                    let mut seg = p.segment;
                    seg.weight = c;
                    training.push(seg);
                }
            }
        }
        SCRATCH.with(|s| {
            s.set(PathScratch {
                pending,
                vertex,
                branches,
            })
        });
        result
    }
}

/// The MIS weight of emission found by a sampled direction against next-event estimation, and NEE's
/// pdf of it (`nee_pdf`, evaluated only if the direction was not a delta lobe's; 0 if it was, where NEE
/// cannot compete).
#[inline]
fn mis_against_nee(prev_delta: bool, prev_pdf: f32, nee_pdf: impl FnOnce() -> f32) -> (f32, f32) {
    if prev_delta {
        (1.0, 0.0)
    } else {
        let nee_pdf = nee_pdf();
        (power_heuristic(prev_pdf, nee_pdf), nee_pdf)
    }
}

/// Books emission MIS-weighted against NEE (pdf `nee_pdf`, 0 where NEE cannot compete) on the segment
/// that reached it, if it is the endpoint of the last pending segment (whose distance is still open).
#[inline]
fn note_emission(pending: &mut [PendingSegment], emitted: Rgb, nee_pdf: f32) {
    if let Some(last) = pending.last_mut() {
        if last.segment.distance < 0.0 && nee_pdf > 0.0 {
            last.segment.emitted += emitted.element_sum() / 3.0;
            last.segment.emitter_pdf = nee_pdf;
        }
    }
}

/// A sampled continuation.
struct Step {
    wo_world: glam::Vec3,
    /// f·cos / pdf, including the mixture's selection.
    weight: Rgb,
    /// The pdf the direction was drawn with (the mixture's, or the BSDF's at unguided vertices; for a
    /// delta lobe the BSDF branch's probability, used only for MIS against nothing).
    pdf: f32,
    /// The BSDF's own pdf of the direction.
    bsdf_pdf: f32,
    /// The guide's own pdf of the direction (0 at unguided vertices).
    guide_pdf: f32,
    eta: f32,
    strategy: Strategy,
}

impl Step {
    fn delta(&self) -> bool {
        self.strategy == Strategy::Delta
    }
}

/// Samples the next direction at a vertex; `None` ends the path.
#[allow(clippy::too_many_arguments)]
#[inline]
fn sample_direction(
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
