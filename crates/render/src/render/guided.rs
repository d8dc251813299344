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
//! checks after every guided training iteration ([`fallback_threshold`]) whether guiding pays for its
//! cost at all, by comparing their images with the unguided first iteration's (see
//! [`GuidedRenderSettings::fallback`]). Training segments carry per-pixel weights from the
//! image so far ([`relative_pixel_weights`]), so that what is learned from second moments weighs every
//! pixel's relative error alike.
//!
//! The guide is updated (record → update) between iterations only; during an iteration it is
//! read-only. Training segments are handed to the guide after every pass in tile order, so a fixed seed
//! and sample budget give the same learned model and image whatever the number of threads.

use super::combine::{robust_inverse_variance_weights, weighted_image, Combine, IterationImage};
use super::cross_check::cross_check;
use super::fallback::{
    fallback_threshold, fallback_weights, gives_up, pooled_moment_ratio, Fallback,
};
pub use super::iteration::IterationStats;
use super::pixel_weights::relative_pixel_weights;
use super::{next_pass_spp, PassRunner, Progress, ProgressCounter, RenderSettings, RenderStats};
use crate::camera::Camera;
use crate::film::{FilmSpec, Image};
use crate::integrator::{
    GuidedPathIntegrator, GuidedSettings, PathIntegrator, PathSettings, Roulette,
};
use crate::scene::Scene;
use focal_guiding::{GuidingField, UpdateContext};
use std::time::{Duration, Instant};

/// Pixel samples per pass at most during training, bounding the memory of one pass's segments.
pub const MAX_TRAINING_PASS_SAMPLES: u64 = 1 << 20;

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
    /// rendered unguided, without the guide's cost (the Cornell box and veach-mis). No check before
    /// [`FIRST_DECISIVE_CHECK`] gives guiding up, nor one that had nothing to compare ([`gives_up`]).
    /// The output then combines the path tracer's iterations with the guided ones before the fallback
    /// ([`fallback_weights`]).
    pub fallback: bool,
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
    /// The images (two interleaved halves each) of the iterations that rendered, in order: what the
    /// combination weighed, for studying other combinations.
    pub iteration_images: Vec<IterationImage>,
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

/// The share of the guided training iterations, the latest ones, whose images the inverse-variance
/// combination uses besides the final iteration's: by then the guide differs little from the final
/// one. An earlier iteration's guide is worse, and its few samples per pixel hide how much worse (its
/// rare bright paths are missing from both of its halves), so even the raised weights of
/// [`robust_inverse_variance_weights`] would give it its share of the samples.
pub const STABLE_TRAINING_SHARE: f64 = 1.0 / 3.0;

/// Which of the `rendered` iterations (in render order) the inverse-variance combination uses: the
/// final one and the last [`STABLE_TRAINING_SHARE`] of the guided training iterations (at least one).
/// The unguided first iteration is used only when nothing was guided: its heavy-tailed noise (the rare
/// path through a pinhole) is exactly what its two-halves variance estimate misses.
pub fn combined_iterations(rendered: &[&IterationStats]) -> Vec<bool> {
    let guided_training = rendered.iter().filter(|s| s.guided && s.training).count();
    if !rendered.iter().any(|s| s.guided) {
        return vec![true; rendered.len()];
    }
    let keep = ((guided_training as f64 * STABLE_TRAINING_SHARE).ceil() as usize).max(1);
    let mut seen = 0;
    rendered
        .iter()
        .map(|s| {
            if !s.guided {
                false
            } else if !s.training {
                true
            } else {
                seen += 1;
                seen + keep > guided_training
            }
        })
        .collect()
}

/// Runs a guided render: training iterations that update `guide`, then the final render. With no guide
/// the whole budget is one unguided iteration (the path tracer without Russian roulette, unless enabled).
pub fn render_guided(
    scene: &Scene,
    camera: &Camera,
    spec: &FilmSpec,
    mut guide: Option<&mut dyn GuidingField>,
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
        let mut contribution_sums = [0.0f64; 2];
        let mut record_s = 0.0;
        // The iteration's training samples, kept apart from the guide until its update.
        let mut samples = match (&guide, training) {
            (Some(g), true) => Some(g.new_samples()),
            _ => None,
        };
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
                runner.run_pass(&unguided, count, &on_tile);
                Vec::new()
            } else {
                let integrator = GuidedPathIntegrator {
                    settings: settings.integrator,
                    guide: if guided { guide.as_deref() } else { None },
                };
                if training {
                    runner.run_recording_pass(&integrator, count, &on_tile)
                } else {
                    runner.run_pass(&integrator, count, &on_tile);
                    Vec::new()
                }
            };
            if training {
                segments += batch.len() as u64;
                for seg in &batch {
                    let c = seg.weight as f64 * seg.pixel_weight as f64;
                    if c > 0.0 && c.is_finite() {
                        contribution_sums[0] += c;
                        contribution_sums[1] += c * c;
                    }
                }
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
                if let (Some(g), Some(samples)) = (guide.as_deref(), samples.as_mut()) {
                    let t = Instant::now();
                    runner.install(|| g.add_samples(samples, &batch));
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
            effective_segments: if contribution_sums[1] > 0.0 {
                contribution_sums[0] * contribution_sums[0] / contribution_sums[1]
            } else {
                0.0
            },
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
                        threshold,
                        fell_back: gives_up(&c, threshold),
                    });
                }
            }
        }
        // A render that has just given up guiding needs no more guide.
        let learn = training && !fell_back(&fallback) && !runner.cancelled();
        let update = match (&mut guide, samples, learn) {
            (Some(g), Some(samples), true) => {
                let ctx = UpdateContext {
                    iteration: index,
                    training_iterations,
                    final_build: index + 1 == training_iterations,
                    threads: runner.threads(),
                };
                Some(runner.install(|| g.update(samples, &ctx)))
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
            let rendered: Vec<&IterationStats> = stats.iter().filter(|s| s.spp > 0).collect();
            fallback_weights(&images, &rendered)
        }
        Combine::InverseVariance => {
            let rendered: Vec<&IterationStats> = stats.iter().filter(|s| s.spp > 0).collect();
            let eligible = combined_iterations(&rendered);
            // Sample counts as the cost (not seconds): the image must not depend on the machine's load.
            let (its, cost): (Vec<IterationImage>, Vec<f64>) = images
                .iter()
                .zip(&eligible)
                .filter(|(_, &e)| e)
                .map(|(i, _)| (i.clone(), i.spp() as f64))
                .unzip();
            let w = robust_inverse_variance_weights(&its, &cost);
            let mut it = w.into_iter();
            eligible
                .iter()
                .map(|&e| if e { it.next().unwrap_or(0.0) } else { 0.0 })
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
        iteration_images: images,
    }
}

#[cfg(test)]
mod tests {
    use super::super::cross_check::CrossCheck;
    use super::super::fallback::*;
    use super::*;

    #[test]
    fn the_first_checks_never_give_guiding_up() {
        for check in 0..FIRST_DECISIVE_CHECK {
            for ratio in [None, Some(0.5), Some(1.5)] {
                assert_eq!(fallback_threshold(check, ratio), f64::INFINITY);
            }
        }
        let k = FIRST_DECISIVE_CHECK;
        assert_eq!(fallback_threshold(k, Some(1.5)), FIRST_THRESHOLD);
        assert_eq!(fallback_threshold(k, None), FIRST_THRESHOLD);
        assert_eq!(
            fallback_threshold(k, Some(0.85)),
            FIRST_THRESHOLD_WITHOUT_MOMENT_GAIN
        );
        assert_eq!(fallback_threshold(k + 1, Some(0.85)), LATER_THRESHOLD);
        assert_eq!(fallback_threshold(k + 5, Some(1.5)), LATER_THRESHOLD);
    }

    #[test]
    fn fallback_never_gives_up_where_the_guide_has_a_strong_moment_gain() {
        for check in [FIRST_DECISIVE_CHECK, FIRST_DECISIVE_CHECK + 1, 9] {
            assert_eq!(
                fallback_threshold(check, Some(MOMENT_GAIN_TO_KEEP_GUIDING)),
                f64::INFINITY
            );
            assert_eq!(fallback_threshold(check, Some(24.0)), f64::INFINITY);
            assert!(fallback_threshold(check, Some(1.9)).is_finite());
        }
    }

    #[test]
    fn the_combination_uses_the_final_and_the_last_third_of_the_guided_training() {
        let it = |guided: bool, training: bool| IterationStats {
            guided,
            training,
            ..iteration([0.0; 2])
        };
        let unguided = it(false, true);
        let train = it(true, true);
        let last = it(true, false);
        let mut rendered = vec![&unguided];
        rendered.extend(std::iter::repeat_n(&train, 7));
        rendered.push(&last);
        let used = combined_iterations(&rendered);
        // ceil(7 / 3) = 3 training iterations, the latest, and the final one.
        assert_eq!(
            used,
            [false, false, false, false, false, true, true, true, true]
        );
        // Without guided training (a loaded guide) only the final one; without guiding, everything.
        assert_eq!(combined_iterations(&[&last]), [true]);
        assert_eq!(combined_iterations(&[&unguided, &unguided]), [true, true]);
    }

    #[test]
    fn a_comparison_with_nothing_to_go_on_does_not_give_guiding_up() {
        // Both images black (no light found), or the path tracer's error estimated at zero: the ratio
        // is not finite, which says nothing about which estimator is better.
        let check = |ratio: f64| CrossCheck {
            unguided_rel_error: 0.0,
            unguided_s: 1.0,
            guided_rel_error: 0.1,
            guided_s: 1.0,
            inefficiency_ratio: ratio,
            unguided_pixel_share: 0.0,
            guided_pixel_share: 0.0,
        };
        assert!(!gives_up(&check(f64::INFINITY), 1.0));
        assert!(!gives_up(&check(f64::NAN), 1.0));
        assert!(gives_up(&check(1.5), 1.0));
        assert!(!gives_up(&check(1.5), f64::INFINITY));
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
            effective_segments: 0.0,
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

    /// An iteration of `spp` samples in two halves of a 32x32 image of 0.5 with per-sample relative noise
    /// `sigma`.
    fn noisy_iteration(rng: &mut focal_testkit::TestRng, spp: u32, sigma: f64) -> IterationImage {
        let half = |rng: &mut focal_testkit::TestRng| {
            let mut img = Image::new(32, 32);
            let s = sigma / ((spp / 2) as f64).sqrt();
            for p in &mut img.rgb {
                *p = [(0.5 * (1.0 + s * rng.next_normal())) as f32; 3];
            }
            img
        };
        IterationImage {
            a: (half(rng), spp / 2),
            b: (half(rng), spp / 2),
        }
    }

    #[test]
    fn after_a_fallback_the_guided_iterations_count_but_never_above_their_time_share() {
        let mut rng = focal_testkit::TestRng::new(11);
        let stat = |guided: bool, render_s: f64| IterationStats {
            guided,
            render_s,
            ..iteration([0.0; 2])
        };
        // The unguided first iteration (1 s), three guided ones (1 s each, as efficient as the path
        // tracer, or seemingly better), then the path tracer for the rest (7 s).
        let images = vec![
            noisy_iteration(&mut rng, 8, 0.4),
            noisy_iteration(&mut rng, 8, 0.2),
            noisy_iteration(&mut rng, 8, 0.4),
            noisy_iteration(&mut rng, 8, 4.0),
            noisy_iteration(&mut rng, 56, 0.4),
        ];
        let stats = [
            stat(false, 1.0),
            stat(true, 1.0),
            stat(true, 1.0),
            stat(true, 1.0),
            stat(false, 7.0),
        ];
        let rendered: Vec<&IterationStats> = stats.iter().collect();
        let w = fallback_weights(&images, &rendered);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{w:?}");
        // The quiet guided iteration is raised to the path tracer's inefficiency: its time share among the
        // kept iterations (1 s of 10), not more.
        assert!(w[1] <= 1.0 / 9.0 + 0.02, "{w:?}");
        assert!((w[2] - w[1]).abs() < 0.03, "{w:?}");
        // 100 times the variance: left out.
        assert_eq!(w[3], 0.0);
        // The path tracer's iterations share their weight by their samples.
        assert!((w[4] / w[0] - 7.0).abs() < 1e-9, "{w:?}");
    }
}
