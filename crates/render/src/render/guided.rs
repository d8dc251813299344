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
//! checks from [`FALLBACK_GUIDED_ITERATIONS`] guided iterations on whether guiding pays for its cost at
//! all (see [`GuidedRenderSettings::fallback`]). Training segments carry per-pixel weights from the
//! image so far ([`relative_pixel_weights`]), so that what is learned from second moments weighs every
//! pixel's relative error alike.
//!
//! The guide is updated (record → update) between iterations only; during an iteration it is
//! read-only. Training segments are handed to the guide after every pass in tile order, so a fixed seed
//! and sample budget give the same learned model and image whatever the number of threads.

use super::combine::{inverse_variance_weights, weighted_image, Combine, IterationImage};
use super::pixel_weights::relative_pixel_weights;
use super::{next_pass_spp, PassRunner, Progress, ProgressCounter, RenderSettings, RenderStats};
use crate::camera::Camera;
use crate::film::{FilmSpec, Image};
use crate::integrator::{GuidedPathIntegrator, GuidedSettings};
use crate::scene::Scene;
use focal_guiding::{GuidingDistribution, UpdateContext, UpdateStats};
use std::time::{Duration, Instant};

/// Pixel samples per pass at most during training, bounding the memory of one pass's segments.
pub const MAX_TRAINING_PASS_SAMPLES: u64 = 1 << 20;

/// A time-budget render first compares guided and unguided efficiency once this many guided training
/// iterations have rendered.
pub const FALLBACK_GUIDED_ITERATIONS: usize = 3;
/// Guiding is given up only after this many consecutive checks (one after every guided training
/// iteration from the [`FALLBACK_GUIDED_ITERATIONS`]th on, each pooling all guided iterations so far)
/// found it not paying; the first check that finds it paying ends the checks. R is heavy-tailed and
/// grows as the guide learns: a single early check gave up on focal scenes (camera obscura, sms-ring).
pub const FALLBACK_CONFIRMATIONS: u32 = 3;
/// Guiding is given up only if it looks more than this many times less efficient than path tracing
/// (T > margin × R, see `fallback_check`): the guide is still young at the check, and R, a mean of
/// heavy-tailed terms, is more often under- than overestimated. Measured (gmm, 20 s, two runs each),
/// T/R at the third check was 3.7–5.2 on the Cornell box, veach-mis and veach-bidir, but 2.8 once on
/// the camera obscura, where guiding wins, and at most 2.1 on sms-ring: a margin of 2 gave up on those.
/// With 3 it still gave up on the caustic (T/R 3.2: its R rises only after the fifth guided iteration)
/// and on sms-ring in one of two runs each, which is why the check is opt-in. Since the GMM's `f32` pdf
/// kernel, T is 1.5–2.6 at the first check: margin 3 fell back on the Cornell box in one of three runs
/// and on veach-mis in none, while margin 2 (two of three, two of two) also gave up on sms-ring in both
/// of two runs (R 0.34 and 0.53, T 1.5), where guiding wins tenfold.
pub const FALLBACK_MARGIN: f64 = 3.0;

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
    /// Give up guiding if it does not pay (time budget and inverse-variance combination only): from
    /// [`FALLBACK_GUIDED_ITERATIONS`] guided training iterations on, the guided segments' importance-
    /// reweighted second moments tell whether the guide samples better than the BSDF (R, see
    /// `fallback_check`); if guided time per sample over unguided (T) exceeds [`FALLBACK_MARGIN`] × R
    /// at [`FALLBACK_CONFIRMATIONS`] consecutive checks, training stops and the rest of the budget is
    /// rendered unguided, without the guide's cost (the Cornell box and veach-mis: guiding costs 3–5× a
    /// path tracer's time per sample and R ≤ 1). The output then combines the unguided iterations.
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
}

/// Writes [`IterationStats::moments`] as their ratio.
fn serialize_moment_ratio<S: serde::Serializer>(m: &[f64; 2], s: S) -> Result<S::Ok, S::Error> {
    let ratio = (m[0] > 0.0 && m[1].is_finite()).then(|| m[1] / m[0]);
    serde::Serialize::serialize(&ratio, s)
}

/// The outcome of the fallback check ([`GuidedRenderSettings::fallback`]), for the JSON record.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct FallbackCheck {
    /// R: the estimated second moment of BSDF-only sampling over that of the guided mixture, from the
    /// checked iterations' segments.
    pub bsdf_moment_ratio: f64,
    /// T: guided time per sample over unguided time per sample.
    pub time_ratio: f64,
    /// The render went on unguided (T > margin × R at every one of the checks).
    pub fell_back: bool,
    /// Checks made (each after one guided training iteration).
    pub checks: u32,
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

/// One fallback check, pooling every guided iteration so far. Their segments, each sampled with p_mix,
/// give by importance reweighting R, the ratio of the second moment their vertices would have had with
/// the BSDF alone (guide fraction 0) to the one they had (unbiased, and it sees the rare paths the guide
/// found, which a few unguided samples per pixel do not; emission is reweighted together with NEE and
/// every pixel weighs alike, see `TrainingSegment::second_moment_with_fraction`). Guiding is efficient if
/// its time per sample relative to the unguided first iteration's, T, is below R: the costs compared are
/// T (guided) and R (unguided), per unit of second moment and unguided time. `fell_back` is this check's
/// verdict (T > [`FALLBACK_MARGIN`] × R); `checks` is 1. `None` without an unguided first iteration and
/// [`FALLBACK_GUIDED_ITERATIONS`] guided ones.
fn fallback_check(stats: &[IterationStats]) -> Option<FallbackCheck> {
    let rendered: Vec<&IterationStats> = stats.iter().filter(|s| s.spp > 0).collect();
    let first = *rendered.first()?;
    if first.guided {
        return None;
    }
    let guided: Vec<&IterationStats> = rendered.iter().copied().filter(|s| s.guided).collect();
    if guided.len() < FALLBACK_GUIDED_ITERATIONS {
        return None;
    }
    let (m_mix, m_bsdf) = guided
        .iter()
        .fold((0.0, 0.0), |(a, b), s| (a + s.moments[0], b + s.moments[1]));
    if !(m_mix > 0.0 && m_bsdf > 0.0 && m_bsdf.is_finite()) {
        return None;
    }
    let ratio = m_bsdf / m_mix;
    let per_sample = |s: &IterationStats| s.render_s / s.spp.max(1) as f64;
    let guided_time: f64 = guided.iter().map(|s| s.render_s).sum::<f64>()
        / guided.iter().map(|s| s.spp as f64).sum::<f64>().max(1.0);
    let time_ratio = guided_time / per_sample(first).max(1e-12);
    Some(FallbackCheck {
        bsdf_moment_ratio: ratio,
        time_ratio,
        fell_back: ratio * FALLBACK_MARGIN < time_ratio,
        checks: 1,
    })
}

/// The fallback decision as checks come in ([`FALLBACK_CONFIRMATIONS`]).
#[derive(Clone, Copy, Debug, Default)]
struct FallbackState {
    /// The last check, with `checks` counting all checks made.
    last: Option<FallbackCheck>,
    /// Consecutive checks that found guiding not paying.
    against: u32,
    /// No more checks: guiding was found paying, or given up.
    decided: bool,
}

impl FallbackState {
    /// Takes one check's verdict.
    fn take(&mut self, mut check: FallbackCheck) {
        check.checks = self.last.map_or(0, |c| c.checks) + 1;
        if check.fell_back {
            self.against += 1;
            check.fell_back = self.against >= FALLBACK_CONFIRMATIONS;
            self.decided = check.fell_back;
        } else {
            self.decided = true;
        }
        self.last = Some(check);
    }

    /// True once guiding has been given up.
    fn fell_back(&self) -> bool {
        self.last.is_some_and(|c| c.fell_back)
    }
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
    let mut fallback = FallbackState::default();
    let plans = training_plans
        .into_iter()
        .chain(std::iter::once(final_plan));
    for (index, plan) in plans.enumerate() {
        let index = index as u32;
        let training = index < training_iterations;
        if training && (fallback.fell_back() || index > 0 && is_past(&plan)) {
            continue;
        }
        let guided = (index > 0 || settings.pretrained) && guide.is_some() && !fallback.fell_back();
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
            moments,
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
            && guided
            && !fallback.decided
        {
            if let Some(check) = fallback_check(&stats) {
                fallback.take(check);
            }
        }
    }

    let weights = match settings.combine {
        Combine::InverseVariance if fallback.fell_back() => {
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
        fallback: fallback.last,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iteration(guided: bool, spp: u32, render_s: f64, moments: [f64; 2]) -> IterationStats {
        IterationStats {
            index: 0,
            guided,
            training: true,
            spp,
            render_s,
            samples_per_s: 0.0,
            segments: 0,
            moments,
            record_s: 0.0,
            update: None,
            weight: 0.0,
        }
    }

    #[test]
    fn fallback_weighs_the_moment_ratio_against_the_time_ratio() {
        // Unguided: 0.1 s per sample. Guided: 0.4 s per sample (T = 4), three guided iterations.
        let first = iteration(false, 10, 1.0, [0.0, 0.0]);
        let guided = |m_bsdf: f64| {
            vec![
                first.clone(),
                iteration(true, 4, 1.6, [1.0, m_bsdf / 3.0]),
                iteration(true, 2, 0.8, [1.0, m_bsdf / 3.0]),
                iteration(true, 2, 0.8, [1.0, m_bsdf / 3.0]),
            ]
        };
        // R = 1: the guide samples no better than the BSDF and costs 4× → fall back.
        let c = fallback_check(&guided(3.0)).unwrap();
        assert!((c.bsdf_moment_ratio - 1.0).abs() < 1e-12);
        assert!((c.time_ratio - 4.0).abs() < 1e-12);
        assert!(c.fell_back);
        // R = 1.6: T = 4 < 3R → keep guiding.
        assert!(!fallback_check(&guided(4.8)).unwrap().fell_back);
        // Every guided iteration so far counts, pooled; unrendered ones are skipped.
        let mut stats = guided(3.0);
        stats.insert(1, iteration(true, 0, 0.0, [0.0, 0.0]));
        stats.insert(1, iteration(true, 1, 0.4, [1.0, 1e3]));
        let pooled = fallback_check(&stats).unwrap();
        assert!((pooled.bsdf_moment_ratio - 1003.0 / 4.0).abs() < 1e-9);
        assert!(!pooled.fell_back);
        // No unguided first iteration, too few guided ones, or no moments: no decision.
        assert!(fallback_check(&guided(3.0)[1..]).is_none());
        assert!(fallback_check(&guided(3.0)[..3]).is_none());
        assert!(fallback_check(&[
            first.clone(),
            iteration(true, 1, 1.0, [0.0, 0.0]),
            iteration(true, 1, 1.0, [0.0, 0.0]),
            iteration(true, 1, 1.0, [0.0, 0.0])
        ])
        .is_none());
    }

    #[test]
    fn fallback_needs_consecutive_verdicts_and_a_paying_check_ends_the_checks() {
        let check = |fell_back: bool| FallbackCheck {
            bsdf_moment_ratio: 1.0,
            time_ratio: 3.0,
            fell_back,
            checks: 1,
        };
        let mut state = FallbackState::default();
        for k in 1..FALLBACK_CONFIRMATIONS {
            state.take(check(true));
            assert!(!state.fell_back() && !state.decided, "after {k} verdicts");
        }
        state.take(check(true));
        assert!(state.fell_back() && state.decided);
        assert_eq!(state.last.unwrap().checks, FALLBACK_CONFIRMATIONS);
        // One check finding guiding paying, even after verdicts against it, decides for guiding.
        let mut state = FallbackState::default();
        state.take(check(true));
        state.take(check(false));
        assert!(!state.fell_back() && state.decided);
        assert_eq!(state.last.unwrap().checks, 2);
    }
}
