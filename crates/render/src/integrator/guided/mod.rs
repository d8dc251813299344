//! Guided unidirectional path tracing (focal path guiding, Rath et al. 2023 §5): at every non-delta vertex
//! a one-sample mixture of BSDF sampling and a learned [`GuidingField`] proposes the next direction,
//! next-event estimation is MIS-weighted against the mixture pdf, and the path's segments are recorded as
//! training data for the next iteration.

mod direction;
mod recording;
mod roulette;
mod splitting;

pub use roulette::Roulette;

use super::path_trace::{LightEvent, PathObserver, PathTrace, TracedVertex};
use super::{
    bsdf_context, next_event_estimate, power_heuristic, resolve_pass_through, FirstHitAovs,
    Integrator, PassThroughRun, PathSettings,
};
use crate::color::Rgb;
use crate::ray::{offset_ray_origin, CameraRay, Ray};
use crate::sampler::Sampler;
use crate::scene::Scene;
use direction::{sample_direction, VertexGuide};
use focal_guiding::{
    GuidingField, SamplingDistribution, TrainingSegment, EXPLORATION_FRACTION,
    EXPLORATION_PROBABILITY,
};
use recording::{PendingSegment, SegmentRecorder};
use splitting::Splitter;
use std::cell::Cell;

/// Roughness below which a path vertex counts as glossy (Ruppert et al. 2020, as the focal-guiding code):
/// a glossy endpoint can form a virtual image, so the whole line through it is a focal candidate.
pub const GLOSSY_ROUGHNESS: f32 = 0.3;

/// Cosine of the largest angle between the direction a path enters a run of glass vertices with and the
/// direction it leaves them with for the glass to count as a window rather than a lens: behind a pane
/// the light source is where the straight line through the glass points, behind a ball it is not.
pub const STRAIGHT_THROUGH_COS: f32 = 0.985;

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
/// estimator is then exactly the path tracer without Russian roulette). [`Integrator::li`] renders;
/// [`GuidedPathIntegrator::li_recording`] also records the path's training segments (and does not split
/// paths, whose copies would record correlated segments).
pub struct GuidedPathIntegrator<'g> {
    /// Settings.
    pub settings: GuidedSettings,
    /// The guide of this iteration (read-only while rendering).
    pub guide: Option<&'g dyn GuidingField>,
}

/// The buffers a path needs, kept per thread instead of allocated per sample: with a large mixture the
/// guide's per-vertex terms are several KiB, and allocating and zeroing them for every path took about
/// 7 % of a guided render.
#[derive(Default)]
struct PathScratch {
    pending: Vec<PendingSegment>,
    vertex: SamplingDistribution,
    branches: Vec<PathState>,
}

thread_local! {
    static SCRATCH: Cell<PathScratch> = Cell::new(PathScratch::default());
}

/// Where a path (or a split-off copy of it) stands before tracing its next ray.
#[derive(Clone, Copy)]
struct PathState {
    ray: Ray,
    throughput: Rgb,
    /// Product of the relative indices of refraction so far (the roulette's η²).
    eta: f32,
    /// Product of the BSDF albedos so far, divided by the roulette's survivals ([`Roulette::Albedo`]).
    albedo: f32,
    /// Scattering vertices so far.
    depth: u32,
    /// The last vertex, and the pdf of the direction sampled there (the mixture's at guided vertices),
    /// for the MIS weight of emission the ray finds; `prev_delta` if that was a delta lobe.
    prev_p: glam::Vec3,
    prev_pdf: f32,
    prev_delta: bool,
}

impl PathState {
    fn camera(ray: Ray) -> Self {
        PathState {
            ray,
            throughput: Rgb::ONE,
            eta: 1.0,
            albedo: 1.0,
            depth: 0,
            prev_p: ray.o,
            prev_pdf: 1.0,
            prev_delta: true,
        }
    }

    /// Emission `le` found along the path's ray, MIS-weighted against next-event estimation (whose pdf
    /// of it `nee_pdf` gives, evaluated only if the last vertex was not a delta lobe's), and NEE's pdf
    /// (0 where NEE cannot compete).
    #[inline]
    fn emission(&self, le: Rgb, nee_pdf: impl FnOnce() -> f32) -> (Rgb, f32) {
        let (mis, nee_pdf) = mis_against_nee(self.prev_delta, self.prev_pdf, nee_pdf);
        (self.throughput * le * mis, nee_pdf)
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
    ) -> Rgb {
        self.trace_path(scene, ray, sampler, aovs, None, &mut ())
    }
}

impl GuidedPathIntegrator<'_> {
    /// [`Integrator::li`] that also appends the path's training segments to `training`.
    pub fn li_recording(
        &self,
        scene: &Scene,
        ray: &CameraRay,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
        training: &mut Vec<TrainingSegment>,
    ) -> Rgb {
        self.trace_path(scene, ray, sampler, aovs, Some(training), &mut ())
    }

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
        self.trace_path(scene, ray, sampler, &mut aovs, None, trace)
    }

    /// The path loop: trace the ray; add emission found (MIS against NEE); at a scattering vertex,
    /// next-event estimation and the next direction from the BSDF/guide mixture; roulette; splitting.
    /// Split-off copies are continued after the path ends.
    fn trace_path<O: PathObserver>(
        &self,
        scene: &Scene,
        camera_ray: &CameraRay,
        sampler: &mut Sampler,
        aovs: &mut FirstHitAovs,
        training: Option<&mut Vec<TrainingSegment>>,
        observer: &mut O,
    ) -> Rgb {
        let s = &self.settings.path;
        if s.max_depth == 0 {
            return Rgb::ZERO;
        }
        let PathScratch {
            pending,
            mut vertex,
            mut branches,
        } = SCRATCH.with(Cell::take);
        branches.clear();
        let mut recorder = SegmentRecorder::new(pending, training.is_some());
        let roulette = self.settings.roulette.for_path(self.guide.is_some());
        let mut splitter = Splitter::new(
            self.settings.split && !recorder.records() && roulette == Roulette::Albedo,
        );
        let mut result = Rgb::ZERO;
        let mut path = PathState::camera(camera_ray.ray);
        let mut run = PassThroughRun::default();

        loop {
            // Whether the path goes on after this ray; if not, a split-off copy continues, if any.
            let goes_on = 'vertex: {
                let visible = !(s.hide_emitters && path.depth == 0);
                let Some(si) = scene.intersect(&path.ray) else {
                    if let (Some(env), true) = (scene.environment, visible) {
                        let d = path.ray.d;
                        let le = scene.emitters[env as usize].eval_environment(d);
                        let (emitted, nee_pdf) =
                            path.emission(le, || scene.pdf_emitter_direction_env(d));
                        result += emitted;
                        recorder.emission(emitted, nee_pdf);
                        observer.light(
                            path.depth,
                            LightEvent::Environment,
                            emitted.element_sum() / 3.0,
                        );
                    }
                    recorder.escaped(path.ray.d, self.settings.train_escaped);
                    break 'vertex false;
                };
                if let Some(e) = scene.shapes[si.shape as usize].emitter {
                    let le = scene.emitters[e as usize].eval_area(si.to_local(-path.ray.d).z);
                    if visible && le != Rgb::ZERO {
                        let (emitted, nee_pdf) = path
                            .emission(le, || scene.pdf_emitter_direction_area(path.prev_p, &si));
                        result += emitted;
                        recorder.emission(emitted, nee_pdf);
                        observer.light(
                            path.depth,
                            LightEvent::EmitterHit,
                            emitted.element_sum() / 3.0,
                        );
                    }
                }
                let ctx = bsdf_context(
                    scene,
                    &si,
                    camera_ray.differential.as_ref(),
                    path.depth == 0,
                );
                // A pass-through is no vertex: no guiding, no training vertex, no depth; the MIS state of the
                // last vertex stays.
                let Some(bsdf) = resolve_pass_through(
                    &scene.bsdfs[scene.shapes[si.shape as usize].bsdf as usize],
                    &ctx,
                    sampler,
                    &mut path.throughput,
                ) else {
                    match run.pass(&path.ray, &si, path.throughput) {
                        Some(next) => {
                            path.ray = next;
                            break 'vertex true;
                        }
                        None => break 'vertex false,
                    }
                };
                let distance = run.end(si.t);
                let glossy = bsdf.min_roughness() < GLOSSY_ROUGHNESS;
                recorder.reached(
                    distance,
                    glossy,
                    glossy && bsdf.has_transmission(),
                    path.ray.d,
                );
                if path.depth == 0 {
                    aovs.albedo = bsdf.albedo(&ctx);
                    aovs.normal = si.sh_frame.n;
                    aovs.depth = distance;
                }
                if path.depth.saturating_add(1) >= s.max_depth {
                    break 'vertex false;
                }

                let wi = si.to_local(-path.ray.d);
                let guide = if bsdf.has_smooth() {
                    self.vertex_guide(si.p, glossy, sampler)
                } else {
                    None
                };
                // The hemisphere the BSDF reflects into (shading normal on the incident side), for guides
                // that can truncate their sampling to it.
                let hint = (self.settings.hemisphere_hint && !bsdf.has_transmission())
                    .then(|| si.sh_frame.n * wi.z.signum());
                if let Some(g) = guide {
                    g.guide.init(&mut vertex, si.p, hint);
                }

                // Next-event estimation, MIS-weighted against the full sampling mixture.
                let direct = path.throughput
                    * next_event_estimate(scene, &si, bsdf, &ctx, wi, sampler, |wo, wo_world| {
                        let p_bsdf = bsdf.pdf(&ctx, wi, wo);
                        match guide {
                            Some(g) => g.mixture_pdf(&vertex, p_bsdf, wo_world).0,
                            None => p_bsdf,
                        }
                    });
                result += direct;
                if direct != Rgb::ZERO {
                    observer.light(
                        path.depth,
                        LightEvent::NextEvent,
                        direct.element_sum() / 3.0,
                    );
                }

                // Direction sampling: BSDF, or the one-sample BSDF/guide mixture.
                let Some(step) = sample_direction(bsdf, guide, &vertex, &ctx, &si, wi, sampler)
                else {
                    break 'vertex false;
                };
                recorder.scattered(step.eta);
                let guide_fraction = guide.map_or(0.0, |g| g.alpha);
                if !step.delta() {
                    recorder.sampled(si.p, &step, guide_fraction, glossy, result);
                }
                path.throughput *= step.weight;
                observer.vertex(TracedVertex {
                    depth: path.depth,
                    bsdf: bsdf.plugin_name(),
                    glossy,
                    guide_fraction,
                    strategy: step.strategy,
                    bsdf_pdf: step.bsdf_pdf,
                    guide_pdf: step.guide_pdf,
                    pdf: step.pdf,
                    weight: step.weight.max_element(),
                    throughput: path.throughput.max_element(),
                    survival: 1.0,
                    split: 1.0,
                    branch: 0,
                });
                path.eta *= step.eta;
                path.prev_p = si.p;
                path.prev_pdf = step.pdf;
                path.prev_delta = step.delta();
                path.depth += 1;

                let albedo = || bsdf.albedo(&ctx).max_element();
                if !roulette.survives(&mut path, albedo, s.rr_depth, sampler, observer) {
                    break 'vertex false;
                }
                path.ray = Ray::new(offset_ray_origin(si.p, si.ng, step.wo_world), step.wo_world);
                splitter.split(&mut path, &mut branches, sampler, observer);
                true
            };
            if !goes_on {
                match self.resume(&mut branches, &mut recorder, &mut run, observer) {
                    Some(next) => path = next,
                    None => break,
                }
            }
        }

        let pending = recorder.finish(result, training);
        SCRATCH.with(|s| {
            s.set(PathScratch {
                pending,
                vertex,
                branches,
            })
        });
        result
    }

    /// The next split-off copy to continue once a path has ended, if any.
    fn resume<O: PathObserver>(
        &self,
        branches: &mut Vec<PathState>,
        recorder: &mut SegmentRecorder,
        run: &mut PassThroughRun,
        observer: &mut O,
    ) -> Option<PathState> {
        let next = branches.pop()?;
        observer.resume();
        *run = PassThroughRun::default();
        recorder.resume();
        Some(next)
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
