//! The training schedule of a guided render: iterations of guided path tracing, each learning from the
//! previous ones' segments, the first unguided, then a final render with the learned guide.
//!
//! Two budgets, as in the literature:
//! - **samples** (Müller et al. 2017): iteration k renders 2^k spp; training continues while the budget
//!   left after an iteration is at least twice that iteration (so the final render gets at least half
//!   the budget, a little over half in practice), up to a maximum number of training iterations;
//! - **time** (Rath et al. 2023): training gets a fraction of the total wall time, split into equal,
//!   cumulative per-iteration deadlines (every iteration renders at least one pass); the final
//!   iteration renders until the total budget is spent. Guide updates count against the budget.
//!
//! Under a time budget a training iteration whose deadline has passed before it starts is skipped (a
//! slow guided pass must not push the whole render past its budget), and with `fallback` the render
//! checks after every guided training iteration ([`FALLBACK_THRESHOLDS`]) whether guiding pays for its cost
//! at all, by comparing their images with the unguided first iteration's (see
//! [`GuidedRenderSettings::fallback`]). Training segments carry per-pixel weights from the
//! image so far ([`relative_pixel_weights`]), so that what is learned from second moments weighs every
//! pixel's relative error alike.
//!
//! The guide is updated (record → update) between iterations only; during an iteration it is
//! read-only. Training segments are handed to the guide after every pass in tile order, so a fixed seed
//! and sample budget give the same learned model and image whatever the number of threads.

use super::combine::{inverse_variance_weights, weighted_image, Combine, IterationImage};
use super::cross_check::{cross_check, CrossCheck};
use super::pixel_weights::relative_pixel_weights;
use super::{next_pass_spp, PassRunner, Progress, ProgressCounter, RenderSettings, RenderStats};
use crate::camera::Camera;
use crate::film::{FilmSpec, Image};
use crate::integrator::{
    GuidedPathIntegrator, GuidedSettings, PathIntegrator, PathSettings, Roulette,
};
use crate::scene::Scene;
use focal_guiding::{GuidingDistribution, UpdateContext, UpdateStats};
use std::time::{Duration, Instant};

/// Pixel samples per pass at most during training, bounding the memory of one pass's segments.
pub const MAX_TRAINING_PASS_SAMPLES: u64 = 1 << 20;

/// A time-budget render checks whether guiding pays ([`cross_check`]) after every guided training
/// iteration: guiding is given up at the first check whose ratio of guided to unguided inefficiency
/// (relative error × time) exceeds its threshold, one per check, the last one for all later checks.
/// Later checks matter: the two-halves estimate of a few guided samples per pixel misses their rare
/// bright paths, which show up as the guided iterations accumulate (veach-mis at 768×512, 30 s, two of
/// six seeds: 0.25 and 0.8 at the first two checks, then 1.4, 1.8, 2.1, … 2.8, and 8–9× the path
/// tracer's relMSE when guiding was kept). Their threshold is high because the ratio also climbs on
/// focal scenes where guiding wins by far: up to 1.03 on the lens focus and 1.53 on the glass caustic
/// in the iterative-narrowing iterations (10 s, 62 guided runs of the ten focal scenes). They can also
/// jump: on the glass caustic at 10 s one seed went 0.01, 0.01, 7.55, when the few caustic pixels that
/// carried the path tracer's estimated error stopped differing from the pooled guided image.
/// Each training iteration is 1/15 of half the budget by default, so every check later costs a non-focal
/// scene another 3 % of the time it then renders unguided. The first check's threshold is lower: after
/// one guided iteration the young guide's own noise, which its halves underestimate, still weighs in the
/// comparison in guiding's favour (veach-mis 0.5–0.6 after one guided iteration, 1.2–1.6 after two;
/// the Cornell box 1.2–1.6 and 1.9–2.2). The focal scenes stayed below 0.1 at both checks (20 s,
/// seeds 0–2, both guides; veach-bidir and the door gap were the highest). The guided iterations so far
/// were rendered with young guides, so a ratio near 1 still favours guiding the rest.
pub const FALLBACK_THRESHOLDS: [f64; 3] = [0.3, 1.0, 2.0];

/// The thresholds where the guided vertices' pooled second-moment ratio ([`IterationStats::moments`],
/// BSDF alone over the mixture) is below 1, i.e. where the guide adds local variance rather than
/// finding what the BSDF misses: the second check gives up at 0.5 instead of 1. That ratio is an
/// importance-sampled estimate, steady where nothing is focal: veach-mis at 30 s, seeds 20–23, gave
/// 0.77–0.87 in every guided iteration while the image checks read 0.16–0.22, 0.63–0.75, then
/// 1.16–1.26, …, so guiding was kept for four or five iterations before the 2.0 threshold gave it up.
/// On the focal scenes the second check stayed at most 0.18 (10 s, seeds 0–2 and 40–42: veach-bidir
/// 0.08–0.14 with the GMM guide and up to 0.18 with the octree, the door gap at most 0.08, the lens
/// focus at most 0.05). Later checks keep 2.0:
/// there the image check climbs on focal scenes (veach-bidir to 0.5) while their moment ratio
/// wanders around 1.
pub const FALLBACK_THRESHOLDS_WITHOUT_MOMENT_GAIN: [f64; 3] = [0.3, 0.5, 2.0];

/// Where the guided vertices' pooled second-moment ratio (BSDF alone over the mixture) is at least this,
/// guiding is never given up: the guide finds light the BSDF finds rarely, and the image check is then
/// at the mercy of whether the few samples behind it saw that light. On the glass caustic at 10 s, eight
/// of twelve runs (seeds 70–72 and 80–82, both guides) gave up guiding at the first check (image ratio
/// 1.6–3.4) for 0.12–2.5 relMSE, while without the fallback seeds 70–72 rendered 0.05–0.13; one of them
/// had a ratio of 24 when it gave up (most had about 1: the guide had learned nothing yet, which this
/// rule cannot tell from a scene with nothing to learn). Over the benchmark's recorded runs (more than
/// 1,500), the non-focal scenes' per-iteration ratio stayed at most 1.37 (the Cornell box, 13 runs)
/// and 0.93 (veach-mis, 34 runs), while the focal scenes' median was 0.7–6.4.
pub const MOMENT_GAIN_TO_KEEP_GUIDING: f64 = 2.0;

/// The threshold of the `check`-th fallback check (0-based) given the pooled second-moment ratio of the
/// guided iterations so far (`None` without guided segments): [`FALLBACK_THRESHOLDS`], or
/// [`FALLBACK_THRESHOLDS_WITHOUT_MOMENT_GAIN`] where the ratio is below 1, or infinity (never give up)
/// where it is at least [`MOMENT_GAIN_TO_KEEP_GUIDING`].
pub fn fallback_threshold(check: usize, moment_ratio: Option<f64>) -> f64 {
    let table = match moment_ratio {
        Some(r) if r >= MOMENT_GAIN_TO_KEEP_GUIDING => return f64::INFINITY,
        Some(r) if r < 1.0 => FALLBACK_THRESHOLDS_WITHOUT_MOMENT_GAIN,
        _ => FALLBACK_THRESHOLDS,
    };
    table[check.min(table.len() - 1)]
}

/// The pooled ratio of [`IterationStats::moments`] over `iterations` (BSDF alone over the mixture), if
/// any guided segment was recorded.
fn pooled_moment_ratio<'a>(iterations: impl Iterator<Item = &'a IterationStats>) -> Option<f64> {
    moment_ratio(iterations.fold([0.0f64; 2], |acc, s| {
        [acc[0] + s.moments[0], acc[1] + s.moments[1]]
    }))
}

/// How long a guided render runs and how it is split into iterations.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum TrainingBudget {
    /// A total sample count per pixel, with doubling training iterations (at most `max_iterations`).
    Samples {
        /// Total samples per pixel, training included.
        spp: u32,
        /// Most training iterations.
        max_iterations: u32,
    },
    /// A total wall-time budget.
    Time {
        /// Total seconds, training and guide updates included.
        seconds: f64,
        /// Share of the budget spent in training iterations.
        training_fraction: f64,
        /// Number of training iterations.
        iterations: u32,
        /// An upper bound on the total samples per pixel.
        max_spp: u32,
    },
}

/// Settings of a guided render.
#[derive(Clone, Debug)]
pub struct GuidedRenderSettings {
    /// Seed, threads, AOVs and sampler (the `spp` and `time_limit` fields are ignored: see `budget`).
    pub render: RenderSettings,
    /// The integrator's settings.
    pub integrator: GuidedSettings,
    /// The budget and its split into iterations.
    pub budget: TrainingBudget,
    /// How the iterations' images are combined.
    pub combine: Combine,
    /// The guide is already trained (loaded from a file): no training iterations, the whole budget is
    /// one guided iteration.
    pub pretrained: bool,
    /// Give up guiding if it does not pay (time budget and inverse-variance combination only): after
    /// every guided training iteration the guided images so far are compared with the unguided first
    /// iteration's ([`cross_check`]); if guiding's inefficiency is more than the check's threshold
    /// ([`fallback_threshold`]) times the path tracer's, training stops and the rest of the budget is
    /// rendered unguided, without the guide's cost (the Cornell box and veach-mis). The output then
    /// combines the unguided iterations by their sample counts.
    pub fallback: bool,
}

/// What happened in one iteration, for the JSON record.
#[derive(Clone, Debug, serde::Serialize)]
pub struct IterationStats {
    /// 0 = the first, unguided iteration.
    pub index: u32,
    /// Rendered with a guide.
    pub guided: bool,
    /// Recorded training data (all but the final iteration).
    pub training: bool,
    /// Samples per pixel.
    pub spp: u32,
    /// Wall time of the rendering.
    pub render_s: f64,
    /// Pixel samples per second.
    pub samples_per_s: f64,
    /// Training segments recorded.
    pub segments: u64,
    /// Guided training iterations: over the recorded guided segments, the estimated second moment of
    /// sampling each one's direction by the BSDF alone (guide fraction 0) over that of the mixture it was
    /// sampled with (`TrainingSegment::second_moment_with_fraction`: NEE-aware emission, per-pixel
    /// weights): above 1 where the guide finds contributions the BSDF misses. Kept as its two sums, the
    /// mixture's and the BSDF's (so that iterations can be pooled); the JSON record holds the ratio, or
    /// null without guided segments.
    #[serde(
        rename = "bsdf_moment_ratio",
        serialize_with = "serialize_moment_ratio"
    )]
    pub moments: [f64; 2],
    /// Wall time the guide spent taking this iteration's segments (between passes).
    pub record_s: f64,
    /// The guide update that followed (training iterations only).
    pub update: Option<UpdateStats>,
    /// Weight of this iteration in the output image.
    pub weight: f64,
    /// Guided training iterations: the image-space comparison of the guided iterations so far with the
    /// unguided first one ([`cross_check`]).
    pub cross_check: Option<CrossCheck>,
}

/// Writes [`IterationStats::moments`] as their ratio.
fn serialize_moment_ratio<S: serde::Serializer>(m: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
    serde::Serialize::serialize(&moment_ratio(*m), s)
}

/// The BSDF's over the mixture's second moment from their sums `[mixture, bsdf]`
/// ([`IterationStats::moments`]), if there was a guided segment and the sum is finite.
fn moment_ratio([mix, bsdf]: [f64; 2]) -> Option<f64> {
    (mix > 0.0 && bsdf.is_finite()).then(|| bsdf / mix)
}

/// The result of a guided render.
pub struct GuidedOutput {
    /// The combined image.
    pub image: Image,
    /// Totals over all iterations (`seconds` is the whole wall time, updates included).
    pub stats: RenderStats,
    /// Per-iteration statistics.
    pub iterations: Vec<IterationStats>,
    /// The latest fallback check's decision (the one that gave up guiding, if any); `None` without a
    /// check.
    pub fallback: Option<Fallback>,
}

/// The fallback decision of a render.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Fallback {
    /// The comparison it was made on.
    pub check: CrossCheck,
    /// The render went on unguided (inefficiency ratio above the check's threshold,
    /// [`fallback_threshold`]).
    pub fell_back: bool,
}

/// The spp of each training iteration under a sample budget, and the final iteration's.
pub fn sample_schedule(spp: u32, max_iterations: u32) -> (Vec<u32>, u32) {
    let mut training = Vec::new();
    let mut used = 0u64;
    let mut n = 1u64;
    while (training.len() as u32) < max_iterations && used + 3 * n <= spp as u64 {
        training.push(n as u32);
        used += n;
        n *= 2;
    }
    (training, spp - used as u32)
}

/// Runs a guided render: training iterations that update `guide`, then the final render. With no guide
/// the whole budget is one unguided iteration (the path tracer without Russian roulette, unless enabled).
pub fn render_guided(
    scene: &Scene,
    camera: &Camera,
    spec: &FilmSpec,
    mut guide: Option<&mut dyn GuidingDistribution>,
    settings: &GuidedRenderSettings,
    progress: &(dyn Fn(Progress) + Sync),
) -> GuidedOutput {
    let start = Instant::now();
    // A pretrained render is one iteration, which needs no variance estimate: one film keeps its image
    // the plain ratio Σw·L / Σw, which shards of the render reproduce exactly when merged.
    let halves = settings.combine == Combine::InverseVariance && !settings.pretrained;
    let pixels = spec.crop_size.x as u64 * spec.crop_size.y as u64;
    let max_pass_spp = (MAX_TRAINING_PASS_SAMPLES / pixels.max(1)).clamp(1, 32) as u32;

    // Per iteration: its spp target (samples budget) or deadline (time budget).
    enum Plan {
        Spp(u32),
        Until(Instant),
    }
    let is_past =
        |plan: &Plan| matches!(plan, Plan::Until(deadline) if Instant::now() >= *deadline);
    let (training_plans, final_plan, total_spp_hint): (Vec<Plan>, Plan, u64) = match settings.budget
    {
        TrainingBudget::Samples {
            spp,
            max_iterations,
        } => {
            let iters = if guide.is_some() && !settings.pretrained {
                max_iterations
            } else {
                0
            };
            let (training, last) = sample_schedule(spp, iters);
            (
                training.into_iter().map(Plan::Spp).collect(),
                Plan::Spp(last),
                spp as u64,
            )
        }
        TrainingBudget::Time {
            seconds,
            training_fraction,
            iterations,
            max_spp,
        } => {
            let iters = if guide.is_some() && !settings.pretrained {
                iterations
            } else {
                0
            };
            let per = Duration::from_secs_f64(
                seconds * training_fraction.clamp(0.0, 1.0) / iters.max(1) as f64,
            );
            (
                (1..=iters).map(|k| Plan::Until(start + per * k)).collect(),
                Plan::Until(start + Duration::from_secs_f64(seconds)),
                max_spp as u64,
            )
        }
    };
    let max_total_spp = match settings.budget {
        TrainingBudget::Samples { spp, .. } => spp,
        TrainingBudget::Time { max_spp, .. } => max_spp,
    };
    let training_iterations = training_plans.len() as u32;
    let counter = ProgressCounter::new(progress, pixels * total_spp_hint, start);
    let on_tile = |n: u64| counter.add(n);

    let mut images: Vec<IterationImage> = Vec::new();
    let mut stats: Vec<IterationStats> = Vec::new();
    let mut last_runner_threads = 0;
    let mut rejected = 0u64;
    let mut total_spp = 0u32;
    // The latest check's decision: it stops changing once a check gives up guiding.
    let mut fallback: Option<Fallback> = None;
    let fell_back = |f: &Option<Fallback>| f.is_some_and(|f| f.fell_back);
    let plans = training_plans
        .into_iter()
        .chain(std::iter::once(final_plan));
    // The same estimator as the guided integrator without a guide (throughput roulette unless off).
    let unguided = PathIntegrator {
        settings: PathSettings {
            russian_roulette: settings.integrator.roulette != Roulette::Off,
            ..settings.integrator.path
        },
    };
    for (index, plan) in plans.enumerate() {
        let index = index as u32;
        let training = index < training_iterations;
        // Asked to stop: the iterations finished so far are combined as usual.
        if settings.render.cancel.is_set() {
            break;
        }
        if training && (fell_back(&fallback) || index > 0 && is_past(&plan)) {
            continue;
        }
        let guided = (index > 0 || settings.pretrained) && guide.is_some() && !fell_back(&fallback);
        let mut runner = PassRunner::new(scene, camera, spec, &settings.render, halves)
            .with_index_offset(total_spp);
        if training && guided {
            runner.set_pixel_weights(relative_pixel_weights(
                &images,
                spec.crop_size.x,
                spec.crop_size.y,
            ));
        }
        last_runner_threads = runner.threads();
        let iter_start = Instant::now();
        let mut segments = 0u64;
        let mut moments = [0.0f64; 2];
        let mut record_s = 0.0;
        let mut pass_spp = 1u32;
        while !runner.cancelled() {
            let spp_left = max_total_spp.saturating_sub(total_spp + runner.spp_done());
            let count = match plan {
                Plan::Spp(target) => pass_spp.min(target.saturating_sub(runner.spp_done())),
                Plan::Until(_) => pass_spp,
            }
            .min(spp_left)
            .min(if training { max_pass_spp } else { u32::MAX });
            if count == 0 {
                break;
            }
            let pass_start = Instant::now();
            let batch = if fell_back(&fallback) {
                // Given up on guiding: the rest is rendered by the path tracer itself.
                runner.run_pass(&unguided, count, &on_tile)
            } else {
                let integrator = GuidedPathIntegrator {
                    settings: GuidedSettings {
                        record_empty: training
                            && guide.as_deref().is_some_and(|g| g.wants_empty_segments()),
                        ..settings.integrator
                    },
                    guide: if guided { guide.as_deref() } else { None },
                    record: training,
                };
                runner.run_pass(&integrator, count, &on_tile)
            };
            if training {
                segments += batch.len() as u64;
                if guided {
                    for seg in batch.iter().filter(|s| s.guide_fraction > 0.0) {
                        let mix = seg.second_moment_with_fraction(seg.guide_fraction);
                        let bsdf = seg.second_moment_with_fraction(0.0);
                        if let (Some(mix), Some(bsdf)) = (mix, bsdf) {
                            if mix.is_finite() && bsdf.is_finite() {
                                moments[0] += mix;
                                moments[1] += bsdf;
                            }
                        }
                    }
                }
                if let Some(g) = guide.as_deref_mut() {
                    let t = Instant::now();
                    runner.install(|| g.record(&batch));
                    record_s += t.elapsed().as_secs_f64();
                }
            }
            pass_spp = match plan {
                Plan::Spp(_) => (pass_spp * 2).min(32),
                Plan::Until(deadline) => match next_pass_spp(pass_spp, count, pass_start, deadline)
                {
                    Some(n) => n,
                    // Every training iteration gets two samples per pixel, so that its halves give a
                    // variance (the first one's for the weights, the guided ones' for the fallback).
                    None if training && halves && runner.spp_done() < 2 => 1,
                    None => break,
                },
            };
        }
        let render_s = iter_start.elapsed().as_secs_f64() - record_s;
        let spp = runner.spp_done();
        total_spp += spp;
        rejected += runner.rejected_samples();
        if spp > 0 {
            images.push(match runner.develop_halves() {
                Some([a, b]) => IterationImage { a, b },
                None => IterationImage {
                    a: (runner.develop(), spp),
                    b: (Image::new(0, 0), 0),
                },
            });
        }
        stats.push(IterationStats {
            index,
            guided,
            training,
            spp,
            render_s,
            samples_per_s: (pixels * spp as u64) as f64 / render_s.max(1e-9),
            segments,
            moments,
            record_s,
            update: None,
            weight: 0.0,
            cross_check: None,
        });
        let mut check = None;
        if training && guided && spp > 0 {
            // Images exist for the iterations that rendered, in order.
            let mut rendered = stats.iter().filter(|s| s.spp > 0).zip(&images);
            if let Some((first, unguided)) = rendered.next().filter(|(s, _)| !s.guided) {
                let guided_images: Vec<(&IterationImage, f64)> = rendered
                    .filter(|(s, _)| s.guided)
                    .map(|(s, i)| (i, s.render_s))
                    .collect();
                check = cross_check(unguided, first.render_s, &guided_images);
                let checking = settings.fallback
                    && halves
                    && matches!(settings.budget, TrainingBudget::Time { .. })
                    && !settings.pretrained
                    && !fell_back(&fallback);
                if let (true, Some(c)) = (checking, check) {
                    let moment_ratio =
                        pooled_moment_ratio(stats.iter().filter(|s| s.guided && s.training));
                    let threshold = fallback_threshold(guided_images.len() - 1, moment_ratio);
                    fallback = Some(Fallback {
                        check: c,
                        fell_back: c.inefficiency_ratio > threshold,
                    });
                }
            }
        }
        // A render that has just given up guiding needs no more guide.
        let learn = training && !fell_back(&fallback) && !runner.cancelled();
        let update = match (&mut guide, learn) {
            (Some(g), true) => {
                let ctx = UpdateContext {
                    iteration: index,
                    training_iterations,
                    final_build: index + 1 == training_iterations,
                    threads: runner.threads(),
                };
                Some(runner.install(|| g.update(&ctx)))
            }
            _ => None,
        };
        if let Some(last) = stats.last_mut() {
            last.update = update;
            last.cross_check = check;
        }
    }

    let weights = match settings.combine {
        Combine::InverseVariance if fell_back(&fallback) => {
            // The unguided iterations are one estimator: weight them by their samples. The guided ones
            // before the check are left out: weighting them by the check's variance estimates, which
            // are rough after one or two iterations, doubled veach-mis's error in one of six runs.
            let used: Vec<&IterationStats> = stats.iter().filter(|s| s.spp > 0).collect();
            let total: f64 = used
                .iter()
                .filter(|s| !s.guided)
                .map(|s| s.spp as f64)
                .sum();
            used.iter()
                .map(|s| if s.guided { 0.0 } else { s.spp as f64 / total })
                .collect()
        }
        Combine::InverseVariance => {
            // An unguided iteration's heavy-tailed noise (the rare path through a pinhole) is exactly what
            // its two-halves variance estimate misses, so it would get too much weight: once some
            // iteration is guided, only guided iterations are combined.
            let guided: Vec<bool> = stats
                .iter()
                .filter(|s| s.spp > 0)
                .map(|s| s.guided)
                .collect();
            let any_guided = guided.iter().any(|&g| g);
            let eligible: Vec<IterationImage> = images
                .iter()
                .zip(&guided)
                .filter(|(_, &g)| g || !any_guided)
                .map(|(i, _)| i.clone())
                .collect();
            let w = inverse_variance_weights(&eligible);
            let mut it = w.into_iter();
            guided
                .iter()
                .map(|&g| {
                    if g || !any_guided {
                        it.next().unwrap_or(0.0)
                    } else {
                        0.0
                    }
                })
                .collect()
        }
        Combine::Last => {
            let mut w = vec![0.0; images.len()];
            if let Some(l) = w.last_mut() {
                *l = 1.0;
            }
            w
        }
    };
    // Iterations that rendered nothing have no image; weights follow the images in order.
    let mut wi = weights.iter();
    for s in stats.iter_mut().filter(|s| s.spp > 0) {
        s.weight = *wi.next().unwrap_or(&0.0);
    }
    let image = if images.is_empty() {
        Image::new(spec.crop_size.x, spec.crop_size.y)
    } else {
        weighted_image(&images, &weights)
    };
    let seconds = start.elapsed().as_secs_f64();
    GuidedOutput {
        image,
        stats: RenderStats {
            spp: total_spp,
            seconds,
            samples_per_second: (pixels * total_spp as u64) as f64 / seconds.max(1e-9),
            passes: stats.len() as u32,
            rejected_samples: rejected,
            threads: last_runner_threads,
        },
        iterations: stats,
        fallback,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fallback_threshold_drops_at_the_second_check_without_moment_gain() {
        assert_eq!(fallback_threshold(0, Some(0.5)), FALLBACK_THRESHOLDS[0]);
        assert_eq!(fallback_threshold(1, Some(1.5)), FALLBACK_THRESHOLDS[1]);
        assert_eq!(fallback_threshold(1, None), FALLBACK_THRESHOLDS[1]);
        assert_eq!(fallback_threshold(1, Some(0.85)), 0.5);
        const { assert!(FALLBACK_THRESHOLDS[1] > FALLBACK_THRESHOLDS_WITHOUT_MOMENT_GAIN[1]) };
        assert_eq!(fallback_threshold(7, Some(0.85)), FALLBACK_THRESHOLDS[2]);
        assert_eq!(fallback_threshold(7, Some(1.5)), FALLBACK_THRESHOLDS[2]);
    }

    #[test]
    fn fallback_never_gives_up_where_the_guide_has_a_strong_moment_gain() {
        for check in [0, 1, 7] {
            assert_eq!(
                fallback_threshold(check, Some(MOMENT_GAIN_TO_KEEP_GUIDING)),
                f64::INFINITY
            );
            assert_eq!(fallback_threshold(check, Some(24.0)), f64::INFINITY);
            assert!(fallback_threshold(check, Some(1.9)).is_finite());
        }
    }

    fn iteration(moments: [f64; 2]) -> IterationStats {
        IterationStats {
            index: 0,
            guided: true,
            training: true,
            spp: 2,
            render_s: 1.0,
            samples_per_s: 1.0,
            segments: 1,
            moments,
            record_s: 0.0,
            update: None,
            weight: 0.0,
            cross_check: None,
        }
    }

    #[test]
    fn pooled_moment_ratio_sums_before_dividing() {
        let its = [iteration([1.0, 3.0]), iteration([3.0, 1.0])];
        assert_eq!(pooled_moment_ratio(its.iter()), Some(1.0));
        assert_eq!(pooled_moment_ratio(std::iter::empty()), None);
        let inf = [iteration([1.0, f64::INFINITY])];
        assert_eq!(pooled_moment_ratio(inf.iter()), None);
    }
}
