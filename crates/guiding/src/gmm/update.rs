//! The GMM guide's update as a pipeline of named steps: where the schedule stands, (experimental
//! reweighting,) dropping a mixture with a negligible share, drawing points along the rays, fitting
//! both mixtures by EM, and balancing them by their weights (p_div).

use std::time::Instant;

use super::em::{fit, FitReport};
use super::guide::{GmmGuide, MixtureState};
use super::mixture::Mixture;
use super::rays::{
    effective_count, generate_points, mix64, NarrowingTable, PointSampling, TrainingRay,
    WeightedPoint,
};
use super::samples::GmmSamples;
use crate::{UpdateContext, UpdateStats};

/// A mixture holding less than this share of the total (decayed + new) training weight is dropped: it
/// would cost as much per pdf evaluation as a useful one while adding nothing to the sampling
/// (observed: docs/experiments/2026-12-01-gmm-mixture-cost.md).
pub const MIN_MIXTURE_SHARE: f64 = 1e-3;
/// The most points drawn along one ray when rays are few (`PointsConfig::min`).
const MAX_ADAPTIVE_POINTS_PER_RAY: usize = 64;

/// Where the schedule stands for the iteration whose data an update takes.
#[derive(Clone, Copy, Debug)]
struct Phase {
    /// Factor on the statistics of earlier iterations.
    decay: f64,
    /// Points are drawn by iterative narrowing.
    narrowing: bool,
}

/// Which mixtures an update dropped for their negligible share.
#[derive(Clone, Copy, Debug, Default)]
struct Dropped {
    conv: bool,
    div: bool,
}

/// The points an update fits, per mixture.
struct Points {
    conv: Vec<WeightedPoint>,
    div: Vec<WeightedPoint>,
    /// Some mixture's points were drawn by narrowing.
    narrowed: bool,
    seconds: f64,
}

/// What the two fits did.
struct Fits {
    conv: FitReport,
    div: FitReport,
    seconds: f64,
}

impl GmmGuide {
    /// The update from one iteration's stored rays (`segments` segments were added to the storage).
    pub(super) fn run_update(
        &mut self,
        mut rays: GmmSamples,
        segments: u64,
        context: &UpdateContext,
    ) -> UpdateStats {
        let start = Instant::now();
        let phase = self.phase(context);
        #[cfg(feature = "experimental")]
        for r in [&mut rays.conv, &mut rays.div] {
            self.config.experimental.reweight(r);
        }
        let dropped = self.drop_negligible_mixtures(&mut rays, phase.decay);
        let points = self.draw_points(&rays, phase, context.iteration);
        self.count_effective_rays(&rays, phase.decay);
        let fits = self.fit_mixtures(&points, phase.decay, context.iteration);
        self.balance_mixtures();
        self.updates += 1;
        let mut stats = self.update_stats(&rays, &points, &fits, dropped, phase);
        stats.segments = segments;
        stats.seconds = start.elapsed().as_secs_f64();
        stats
    }

    /// The schedule's decay and narrowing for the data of `context.iteration`.
    fn phase(&self, context: &UpdateContext) -> Phase {
        let schedule = &self.config.schedule;
        let (i, n) = (context.iteration, context.training_iterations);
        Phase {
            decay: schedule.decay_before(i, n),
            narrowing: schedule.narrows(i, n),
        }
    }

    /// Drops a mixture whose data (decayed statistics and new rays) would hold a negligible share of
    /// the total: no fit, no pdf cost.
    fn drop_negligible_mixtures(&mut self, rays: &mut GmmSamples, decay: f64) -> Dropped {
        let ray_mass = |rays: &[TrainingRay]| rays.iter().map(TrainingRay::mass).sum::<f64>();
        let mass_conv = decay * self.conv.weight() + ray_mass(&rays.conv);
        let mass_div = decay * self.div.weight() + ray_mass(&rays.div);
        let total_mass = mass_conv + mass_div;
        let negligible = |m: f64| total_mass > 0.0 && m < MIN_MIXTURE_SHARE * total_mass;
        let dropped = Dropped {
            conv: negligible(mass_conv),
            div: negligible(mass_div),
        };
        if dropped.conv {
            self.conv = MixtureState::default();
            rays.conv.clear();
        }
        if dropped.div {
            self.div = MixtureState::default();
            rays.div.clear();
        }
        dropped
    }

    /// Points along every mixture's rays: stratified uniform, or while narrowing, drawn against the
    /// mixture the rays were rendered with; at least `points.per_ray` per ray, more (up to 64) when rays
    /// are few, at most `points.max` per mixture.
    fn draw_points(&self, rays: &GmmSamples, phase: Phase, iteration: u32) -> Points {
        let start = Instant::now();
        let p = &self.config.points;
        let min_per_ray = p.per_ray as usize;
        let min_points = p.min.min(p.max);
        let per_ray_for = |rays: usize| {
            min_per_ray.max((min_points / rays.max(1)).min(MAX_ADAPTIVE_POINTS_PER_RAY))
        };
        let q = self.p_div;
        let seed = self.points_seed(iteration);
        let table = |m: &Mixture, selection: f64| {
            (phase.narrowing && !m.is_empty()).then(|| NarrowingTable::new(m, selection))
        };
        let conv_table = table(&self.conv.mixture, 1.0 - q);
        let div_table = table(&self.div.mixture, q);
        fn sampling(t: &Option<NarrowingTable>) -> PointSampling<'_> {
            t.as_ref()
                .map_or(PointSampling::Uniform, PointSampling::Narrowing)
        }
        let conv = generate_points(
            &rays.conv,
            per_ray_for(rays.conv.len()),
            p.max,
            sampling(&conv_table),
            seed,
        );
        let div = generate_points(
            &rays.div,
            per_ray_for(rays.div.len()),
            p.max,
            sampling(&div_table),
            !seed,
        );
        Points {
            conv,
            div,
            narrowed: conv_table.is_some() || div_table.is_some(),
            seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// The seed of an update's points, from the config's seed and the iteration.
    fn points_seed(&self, iteration: u32) -> u64 {
        mix64(self.config.seed ^ mix64(iteration as u64))
    }

    /// Decays the effective ray counts behind the statistics and adds this update's.
    fn count_effective_rays(&mut self, rays: &GmmSamples, decay: f64) {
        let effective = |rays: &[TrainingRay], previous: f64| {
            decay * previous + effective_count(rays.iter().map(TrainingRay::mass))
        };
        self.effective_rays = [
            effective(&rays.conv, self.effective_rays[0]),
            effective(&rays.div, self.effective_rays[1]),
        ];
    }

    /// Stepwise MAP-EM on each mixture from its decayed statistics and this update's points.
    fn fit_mixtures(&mut self, points: &Points, decay: f64, iteration: u32) -> Fits {
        let start = Instant::now();
        let seed = self.points_seed(iteration);
        let fit_state = |state: &MixtureState, points: &[WeightedPoint], tag: u64| {
            let params = self.fit_params(mix64(seed ^ tag));
            let (mixture, stats, report) =
                fit(&state.mixture, &state.stats, points, decay, &params);
            (MixtureState { mixture, stats }, report)
        };
        let (conv, conv_report) = fit_state(&self.conv, &points.conv, 1);
        let (div, div_report) = fit_state(&self.div, &points.div, 2);
        self.conv = conv;
        self.div = div;
        Fits {
            conv: conv_report,
            div: div_report,
            seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// p_div = W_div / (W_conv + W_div), or all on the mixture that has components.
    fn balance_mixtures(&mut self) {
        let (w_conv, w_div) = (self.conv.weight(), self.div.weight());
        self.p_div = if self.conv.mixture.is_empty() {
            if self.div.mixture.is_empty() {
                0.0
            } else {
                1.0
            }
        } else if self.div.mixture.is_empty() {
            0.0
        } else if w_conv + w_div > 0.0 && (w_conv + w_div).is_finite() {
            w_div / (w_conv + w_div)
        } else {
            0.5
        };
    }

    /// The update's record for the render's JSON.
    fn update_stats(
        &self,
        rays: &GmmSamples,
        points: &Points,
        fits: &Fits,
        dropped: Dropped,
        phase: Phase,
    ) -> UpdateStats {
        let (kc, kd) = (self.conv.mixture.len(), self.div.mixture.len());
        let sum = |f: fn(&FitReport) -> u32| (f(&fits.conv) + f(&fits.div)) as f64;
        let details = vec![
            ("k".into(), (kc + kd) as f64),
            ("k_conv".into(), kc as f64),
            ("k_div".into(), kd as f64),
            ("p_div".into(), self.p_div),
            ("w_conv".into(), self.conv.weight()),
            ("w_div".into(), self.div.weight()),
            ("effective_rays_conv".into(), self.effective_rays[0]),
            ("effective_rays_div".into(), self.effective_rays[1]),
            ("rays".into(), (rays.conv.len() + rays.div.len()) as f64),
            ("rays_conv".into(), rays.conv.len() as f64),
            ("rays_div".into(), rays.div.len() as f64),
            (
                "points".into(),
                (points.conv.len() + points.div.len()) as f64,
            ),
            ("points_conv".into(), points.conv.len() as f64),
            ("points_div".into(), points.div.len() as f64),
            ("em_iterations".into(), sum(|r| r.em_iterations)),
            ("splits".into(), sum(|r| r.splits)),
            ("merges".into(), sum(|r| r.merges)),
            ("prunes".into(), sum(|r| r.prunes)),
            ("loglik_conv".into(), fits.conv.log_likelihood),
            ("loglik_div".into(), fits.div.log_likelihood),
            ("narrowing".into(), points.narrowed as u8 as f64),
            ("dropped_conv".into(), dropped.conv as u8 as f64),
            ("dropped_div".into(), dropped.div as u8 as f64),
            ("decay".into(), phase.decay),
            ("segments_dropped".into(), rays.dropped as f64),
            ("rays_empty".into(), rays.empty as f64),
            ("thinning_rounds".into(), rays.thinned as f64),
            ("points_seconds".into(), points.seconds),
            ("fit_seconds".into(), fits.seconds),
        ];
        UpdateStats {
            segments: 0,
            model_size: (kc + kd) as u64,
            seconds: 0.0,
            details,
        }
    }
}
