//! Weighted MAP-EM of a Gaussian mixture on the points drawn along training rays, with stepwise
//! (online) statistics across updates, weighted k-means++ initialisation, and split/merge/prune.
//!
//! Numerics and determinism:
//! - the E-step is a log-sum-exp over components; responsibilities more than e⁻³⁰ below a point's best
//!   component are dropped (they cannot change any f64 sum noticeably);
//! - statistics are accumulated in `f64` relative to each component's current mean (no cancellation
//!   in E[yyᵀ] − μμᵀ far from the origin), per fixed-size chunk of points, and the chunk sums are added
//!   in chunk order: the model is bit-identical for any thread count;
//! - statistics are kept in moment form (weight, mean, scatter) and combined with Chan's formula;
//! - the hot loops use `mul_add`, which IEEE 754 defines as exactly rounded, so hardware FMA and a
//!   software fallback give the same bits.
//!
//! MAP M-step (a normal-inverse-Wishart-style prior on Σ with a flat prior on μ): with ν = prior
//! strength × the mixture's total weight and σ₀ the prior scale,
//! Σ_k = (S_k + ν σ₀² I) / (n_k + ν) + σ_f² I, where S_k is the scatter and n_k the weight. ν scales with
//! the data, so the fit is invariant to the units of the contributions; σ_f = σ₀/100 is an absolute
//! floor so no component becomes singular even when the data is (all points on one line). Weights are
//! π_k ∝ max(n_k/W, floor).
//!
//! Split criterion (absolute: nats). In the middle EM iteration the points each component is responsible
//! for are binned in the component's whitened frame z = L⁻¹(y − μ) into 4³ cells with edges −1, 0, 1 on
//! each axis (the outer cells reach infinity), whose exact probabilities under the component are
//! products of Φ differences. The binned KL divergence D = Σ_c o_c ln(o_c / p_c) between the observed
//! cell shares o_c and the model's p_c is a lower bound on the KL divergence between the component's
//! data and the component, minus its small-sample bias (cells − 1)/(2 n_eff). A component splits when
//! its weight share × D exceeds the threshold (the mixture-level gain) — two foci inside one broad
//! component, or a focus with its ~1/r² halo of rays, give D ≫ 0, Gaussian data D ≈ 0. The child is
//! born from the over-populated cell with the largest share of D: it takes exactly that cell's
//! statistics (weight, mean, scatter), which are subtracted from the parent (Chan's formula inverted),
//! so the parent's total moments are preserved; the decayed history is divided in the same proportion
//! when that keeps both parts valid, and otherwise stays with the parent. EM then pulls the child onto
//! the density peak inside its cell.
//!
//! Merge: greedily the pair with the smallest Bhattacharyya distance while it is below the threshold;
//! statistics are combined exactly. Prune: components holding less than a minimal share of the weight.
//! Merges and prunes never go below k_min, splits never above k_max; components created or merged in an
//! update are not split or merged again in it (merges run first).

mod estep;
mod init;
mod stats;
mod structure;

use glam::DVec3;

pub use estep::{e_step, EStep, SplitCandidate, E_CHUNK};
pub use init::kmeans_init;
pub use stats::SuffStats;

use super::gaussian::Gaussian3;
use super::mixture::Mixture;
use super::rays::WeightedPoint;
use super::sym3::Sym3;
use structure::{restructure, Entry};

/// A component needs this many effective points before its binned divergence is trusted. Points, not
/// rays: the points along one ray are correlated, but the structure the divergence sees is real even
/// when few rays show it, and counting rays instead stopped all splits on the obscura and door-gap
/// scenes (docs/experiments/2026-12-01-gmm-split-criterion.md).
pub(super) const MIN_SPLIT_POINTS: f64 = 512.0;
/// A birth cell must hold at least this share of its component's binned weight.
pub(super) const MIN_BIRTH_SHARE: f64 = 0.01;

/// Parameters of one fit, in the guide's unit frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitParams {
    /// Components k-means++ starts with.
    pub k_init: usize,
    /// Merges and prunes stop here.
    pub k_min: usize,
    /// Splits stop here (≤ [`crate::gmm::MAX_COMPONENTS`]).
    pub k_max: usize,
    /// EM iterations per fit.
    pub em_iterations: u32,
    /// Prior covariance scale σ₀.
    pub prior_sigma: f64,
    /// Prior pseudo-weight ν as a fraction of the mixture's total weight.
    pub prior_strength: f64,
    /// Absolute covariance floor σ_f (added as σ_f² I).
    pub floor_sigma: f64,
    /// Floor on each mixture weight π_k.
    pub weight_floor: f64,
    /// Split when π_k × the binned divergence (nats) exceeds this.
    pub split_threshold: f64,
    /// Merge pairs whose Bhattacharyya distance is below this.
    pub merge_threshold: f64,
    /// Prune components holding less than this share of the weight.
    pub prune_share: f64,
    /// Seed of the initialisation.
    pub seed: u64,
}

/// What a fit did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FitReport {
    /// True if the mixture was initialised by k-means++ in this fit.
    pub initialised: bool,
    /// EM iterations run.
    pub em_iterations: u32,
    /// Components split.
    pub splits: u32,
    /// Pairs merged.
    pub merges: u32,
    /// Components pruned.
    pub prunes: u32,
    /// Mean ln ρ(y) per unit weight over this fit's points in the last E-step.
    pub log_likelihood: f64,
    /// Total weight of this fit's points.
    pub point_weight: f64,
}

/// The MAP Gaussian of `stats` under the covariance prior with pseudo-weight `nu`; `fallback` if that
/// fails (non-finite data), and its mean if the component has no data.
pub(super) fn map_gaussian(
    stats: &SuffStats,
    nu: f64,
    params: &FitParams,
    fallback: &Gaussian3,
) -> Gaussian3 {
    let prior2 = params.prior_sigma * params.prior_sigma;
    let floor = Sym3::scaled_identity(params.floor_sigma * params.floor_sigma);
    let denom = stats.weight + nu;
    let cov = if denom > 0.0 {
        (stats.scatter + Sym3::scaled_identity(nu * prior2)) * (1.0 / denom) + floor
    } else {
        Sym3::scaled_identity(prior2) + floor
    };
    let mean = if stats.weight > 0.0 {
        stats.mean
    } else {
        fallback.mean()
    };
    Gaussian3::new(mean, cov).unwrap_or(*fallback)
}

/// π_k ∝ max(n_k / W, floor), normalised.
fn mixture_weights(stats: &[SuffStats], floor: f64) -> Vec<f64> {
    let total: f64 = stats.iter().map(|s| s.weight).sum();
    let raw: Vec<f64> = stats
        .iter()
        .map(|s| {
            if total > 0.0 {
                (s.weight / total).max(floor)
            } else {
                1.0
            }
        })
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.into_iter().map(|w| w / sum).collect()
}

/// The M-step: MAP parameters of every component from its statistics.
fn m_step(
    stats: &[SuffStats],
    old: &[Gaussian3],
    params: &FitParams,
) -> (Vec<Gaussian3>, Vec<f64>) {
    let nu = params.prior_strength * stats.iter().map(|s| s.weight).sum::<f64>();
    let components = stats
        .iter()
        .zip(old)
        .map(|(s, g)| map_gaussian(s, nu, params, g))
        .collect();
    (components, mixture_weights(stats, params.weight_floor))
}

/// Fits a mixture to this update's `points` (unit frame), continuing from `previous` and its statistics
/// `previous_stats` (decayed by `decay`), or initialising by k-means++ if `previous` is empty. Returns
/// the new mixture, its blended statistics, and a report.
pub fn fit(
    previous: &Mixture,
    previous_stats: &[SuffStats],
    points: &[WeightedPoint],
    decay: f64,
    params: &FitParams,
) -> (Mixture, Vec<SuffStats>, FitReport) {
    let mut report = FitReport::default();
    let decayed: Vec<SuffStats> = if previous_stats.len() == previous.len() {
        previous_stats.iter().map(|s| s.scaled(decay)).collect()
    } else {
        previous
            .components()
            .iter()
            .map(|g| SuffStats {
                weight: 0.0,
                mean: g.mean(),
                scatter: Sym3::ZERO,
            })
            .collect()
    };
    if points.is_empty() {
        return (previous.clone(), decayed, report);
    }
    let (mut components, mut weights, mut prior_stats) = if previous.is_empty() {
        let clusters = kmeans_init(points, params.k_init.min(params.k_max), params.seed);
        if clusters.is_empty() {
            return (previous.clone(), decayed, report);
        }
        report.initialised = true;
        let nu = params.prior_strength * clusters.iter().map(|s| s.weight).sum::<f64>();
        let fallback = Gaussian3::new(
            DVec3::ZERO,
            Sym3::scaled_identity(params.prior_sigma * params.prior_sigma),
        )
        .expect("the prior covariance is positive definite");
        let components: Vec<Gaussian3> = clusters
            .iter()
            .map(|s| map_gaussian(s, nu, params, &fallback))
            .collect();
        let weights = mixture_weights(&clusters, params.weight_floor);
        let zero: Vec<SuffStats> = clusters
            .iter()
            .map(|s| SuffStats {
                weight: 0.0,
                mean: s.mean,
                scatter: Sym3::ZERO,
            })
            .collect();
        (components, weights, zero)
    } else {
        (
            previous.components().to_vec(),
            previous.weights().to_vec(),
            decayed,
        )
    };
    let iterations = params.em_iterations.max(1);
    let structure_at = iterations / 2;
    let mut blended = prior_stats.clone();
    for it in 0..iterations {
        let evaluate = it == structure_at;
        let e = e_step(points, &components, &weights, evaluate);
        report.em_iterations += 1;
        report.point_weight = e.weight;
        report.log_likelihood = if e.weight > 0.0 {
            e.log_likelihood / e.weight
        } else {
            0.0
        };
        blended = prior_stats
            .iter()
            .zip(&e.stats)
            .map(|(p, n)| p.combine(n))
            .collect();
        (components, weights) = m_step(&blended, &components, params);
        if evaluate {
            let mut entries: Vec<Entry> = components
                .iter()
                .zip(&e.stats)
                .zip(&prior_stats)
                .zip(&e.splits)
                .map(|(((c, f), p), s)| Entry {
                    component: *c,
                    fresh: *f,
                    previous: *p,
                    split: *s,
                    touched: false,
                })
                .collect();
            restructure(&mut entries, params, &mut report);
            blended = entries.iter().map(Entry::blended).collect();
            prior_stats = entries.iter().map(|e| e.previous).collect();
            let old: Vec<Gaussian3> = entries.iter().map(|e| e.component).collect();
            (components, weights) = m_step(&blended, &old, params);
        }
    }
    match Mixture::from_normalized(weights, components) {
        Ok(mixture) => (mixture, blended, report),
        Err(_) => (previous.clone(), previous_stats.to_vec(), report),
    }
}
