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
//! checks after [`FALLBACK_GUIDED_ITERATIONS`] guided iterations whether guiding pays for its cost at all (see
//! [`GuidedRenderSettings::fallback`]).
//!
//! The guide is updated (record → update) between iterations only; during an iteration it is
//! read-only. Training segments are handed to the guide after every pass in tile order, so a fixed seed
//! and sample budget give the same learned model and image whatever the number of threads.

use super::combine::{
    inverse_variance_weights, pooled_image, robust_per_sample_relative_variance,
    smoothed_luminance, weighted_image, Combine, IterationImage, ROBUST_DENOMINATOR_RADIUS,
};
use super::{next_pass_spp, PassRunner, Progress, ProgressCounter, RenderSettings, RenderStats};
use crate::camera::Camera;
use crate::film::{FilmSpec, Image};
use crate::integrator::{GuidedPathIntegrator, GuidedSettings};
use crate::scene::Scene;
use focal_guiding::{GuidingDistribution, UpdateContext, UpdateStats};
use std::time::{Duration, Instant};

/// Pixel samples per pass at most during training, bounding the memory of one pass's segments.
pub const MAX_TRAINING_PASS_SAMPLES: u64 = 1 << 20;

/// A time-budget render compares guided and unguided efficiency once this many guided training
/// iterations have rendered.
pub const FALLBACK_GUIDED_ITERATIONS: usize = 2;
/// Guiding is given up only if unguided path tracing is more than this many times as efficient
/// (1 / (per-sample relative variance × time per sample)): the unguided estimate misses rare paths at
/// a few samples per pixel, which flatters it, and the guide is still young at the check.
pub const FALLBACK_MARGIN: f64 = 2.0;

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
    /// [`FALLBACK_GUIDED_ITERATIONS`] guided training iterations, the per-sample relative variances of
    /// the unguided first iteration and of the guided ones are weighed by their time per sample; if
    /// unguided rendering is over [`FALLBACK_MARGIN`] times as efficient, training stops and the rest of
    /// the budget is rendered unguided, without the guide's cost (the Cornell box: guiding costs several
    /// times a path tracer's time per sample and gains nothing). The output then combines the unguided
    /// iterations. The variances are robust estimates (smoothed denominator, trimmed, and for the path
    /// tracer also its difference from the guided mean: see `fallback_check`). Not a default: measured
    /// guided/unguided cost ratios (`--time 10`, gmm, 3–4 seeds) were 1.4–1.95 on the caustic scene and
    /// 2.3–3.05 on the Cornell box, so the margin of 2 separates them, but narrowly; at two guided
    /// iterations the variances say little about the trained guide and the ratio mostly measures the
    /// guide's cost per sample.
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
    /// Wall time the guide spent taking this iteration's segments (between passes).
    pub record_s: f64,
    /// The guide update that followed (training iterations only).
    pub update: Option<UpdateStats>,
    /// Weight of this iteration in the output image.
    pub weight: f64,
}

/// The outcome of the fallback check ([`GuidedRenderSettings::fallback`]), for the JSON record.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FallbackCheck {
    /// The unguided per-sample relative variance used: the larger of the halves' estimate and the
    /// estimate from the difference to the guided mean.
    pub unguided_variance: f64,
    /// The unguided per-sample relative variance from the first iteration's halves alone.
    pub unguided_halves_variance: f64,
    /// The guided per-sample relative variance (from two guided iterations).
    pub guided_variance: f64,
    /// Relative per-sample variance × seconds per sample of unguided rendering.
    pub unguided_cost: f64,
    /// The same for guided rendering.
    pub guided_cost: f64,
    /// The render went on unguided.
    pub fell_back: bool,
}

/// The result of a guided render.
pub struct GuidedOutput {
    /// The combined image.
    pub image: Image,
    /// Totals over all iterations (`seconds` is the whole wall time, updates included).
    pub stats: RenderStats,
    /// Per-iteration statistics.
    pub iterations: Vec<IterationStats>,
    /// The fallback check, if it was made.
    pub fallback: Option<FallbackCheck>,
}

/// The fallback check after the first guided iterations: the unguided first iteration's per-sample
/// relative variance from its halves, the guided one from the last two guided iterations' difference,
/// each times its seconds per sample. `None` if an estimate is missing.
fn fallback_check(images: &[IterationImage], stats: &[IterationStats]) -> Option<FallbackCheck> {
    let rendered: Vec<(&IterationImage, &IterationStats)> = images
        .iter()
        .zip(stats.iter().filter(|s| s.spp > 0))
        .collect();
    let (first, first_stats) = *rendered.first()?;
    if first_stats.guided {
        return None;
    }
    let guided: Vec<&(&IterationImage, &IterationStats)> =
        rendered.iter().filter(|(_, s)| s.guided).collect();
    let [(g1, s1), (g2, s2)] = guided.get(guided.len().checked_sub(2)?..)? else {
        return None;
    };
    let denominator = smoothed_luminance(&pooled_image(images), ROBUST_DENOMINATOR_RADIUS);
    let halves_var = robust_per_sample_relative_variance(
        &first.a.0,
        first.a.1,
        &first.b.0,
        first.b.1,
        &denominator,
    )?;
    let guided_var = robust_per_sample_relative_variance(
        &g1.image(),
        g1.spp(),
        &g2.image(),
        g2.spp(),
        &denominator,
    )?;
    // The halves alone underestimate the path tracer's variance where its contribution is rare: with
    // few samples a caustic pixel is mostly 0 in both halves. Its difference from the (unbiased) guided
    // mean G sees the missing light: E[(U − G)²] = σ_u²/n_u + σ_g²/n_g per pixel, so
    // σ_u² = n_u·(D − σ_g²/n_g) with D the mean relative squared difference.
    let (nu, ng) = (first.spp() as f64, (g1.spp() + g2.spp()) as f64);
    let mut guided_mean = g1.image();
    guided_mean.scale(g1.spp() as f64 / ng);
    guided_mean.add_scaled(&g2.image(), g2.spp() as f64 / ng);
    let mixed = robust_per_sample_relative_variance(
        &first.image(),
        first.spp(),
        &guided_mean,
        ng as u32,
        &denominator,
    )?;
    let difference = mixed * (1.0 / nu + 1.0 / ng);
    let cross_var = nu * (difference - guided_var / ng);
    let unguided_var = halves_var.max(cross_var);
    let per_sample = |s: &IterationStats| s.render_s / s.spp.max(1) as f64;
    let unguided_cost = unguided_var * per_sample(first_stats);
    let guided_cost = guided_var * (s1.render_s + s2.render_s) / (s1.spp + s2.spp).max(1) as f64;
    Some(FallbackCheck {
        unguided_variance: unguided_var,
        unguided_halves_variance: halves_var,
        guided_variance: guided_var,
        unguided_cost,
        guided_cost,
        fell_back: unguided_cost * FALLBACK_MARGIN < guided_cost,
    })
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
    let halves = settings.combine == Combine::InverseVariance;
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
    let mut fallback: Option<FallbackCheck> = None;
    let fell_back = |f: &Option<FallbackCheck>| f.is_some_and(|f| f.fell_back);
    let plans = training_plans
        .into_iter()
        .chain(std::iter::once(final_plan));
    for (index, plan) in plans.enumerate() {
        let index = index as u32;
        let training = index < training_iterations;
        if training && (fell_back(&fallback) || index > 0 && is_past(&plan)) {
            continue;
        }
        let guided = (index > 0 || settings.pretrained) && guide.is_some() && !fell_back(&fallback);
        let mut runner = PassRunner::new(scene, camera, spec, &settings.render, halves)
            .with_index_offset(total_spp);
        last_runner_threads = runner.threads();
        let iter_start = Instant::now();
        let mut segments = 0u64;
        let mut record_s = 0.0;
        let mut pass_spp = 1u32;
        loop {
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
            let batch = {
                let integrator = GuidedPathIntegrator {
                    settings: settings.integrator,
                    guide: if guided { guide.as_deref() } else { None },
                    record: training,
                };
                runner.run_pass(&integrator, count, &on_tile)
            };
            if training {
                segments += batch.len() as u64;
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
                    // The first iteration gets two samples per pixel, so that its halves give a variance.
                    None if index == 0 && halves && runner.spp_done() < 2 => 1,
                    None => break,
                },
            };
        }
        let render_s = iter_start.elapsed().as_secs_f64() - record_s;
        let spp = runner.spp_done();
        total_spp += spp;
        rejected += runner.rejected_samples();
        let update = match (&mut guide, training) {
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
            record_s,
            update,
            weight: 0.0,
        });
        let time_budget = matches!(settings.budget, TrainingBudget::Time { .. });
        if settings.fallback
            && halves
            && time_budget
            && !settings.pretrained
            && training
            && fallback.is_none()
            && stats.iter().filter(|s| s.guided && s.spp > 0).count() == FALLBACK_GUIDED_ITERATIONS
        {
            fallback = fallback_check(&images, &stats);
        }
    }

    let weights = match settings.combine {
        Combine::InverseVariance if fell_back(&fallback) => {
            // The unguided iterations are one estimator: weight them by their samples.
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
