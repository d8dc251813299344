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

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::cumulative::pick_interval;
use super::gaussian::Gaussian3;
use super::mixture::{Mixture, MAX_COMPONENTS};
use super::rays::{mix64, WeightedPoint};
use super::special::{exp_fast, norm_cdf};
use super::sym3::Sym3;

/// Points per E-step work item (fixed, so chunk sums and their order do not depend on the thread count).
pub const E_CHUNK: usize = 4096;
/// Chunks evaluated concurrently before their sums are reduced (in chunk order); bounds the memory of
/// the per-chunk split cells.
const CHUNKS_PER_ROUND: usize = 32;
/// Responsibilities below e^−30 (1e-13) of the point's best component are dropped.
const RESPONSIBILITY_CUTOFF: f64 = 30.0;
/// Points enter a component's split cells if it is responsible for them with at least this probability.
const CELL_MIN_RESPONSIBILITY: f64 = 1e-3;
/// Split cells: 4 per whitened axis.
const CELLS: usize = 64;
/// Points k-means++ seeds on (a deterministic stride subset of the first update's points).
const INIT_SAMPLE: usize = 65_536;
/// Weighted Lloyd iterations after seeding.
const LLOYD_ITERATIONS: usize = 3;
/// A component needs this many effective points before its binned divergence is trusted. Points, not
/// rays: the points along one ray are correlated, but the structure the divergence sees is real even
/// when few rays show it, and counting rays instead stopped all splits on the obscura and door-gap
/// scenes (docs/experiments/2026-12-01-gmm-split-criterion.md).
const MIN_SPLIT_POINTS: f64 = 512.0;
/// A birth cell must hold at least this share of its component's binned weight.
const MIN_BIRTH_SHARE: f64 = 0.01;

/// Weighted statistics of the data a component explains, in moment form.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SuffStats {
    /// Σω.
    pub weight: f64,
    /// Σω y / Σω.
    pub mean: DVec3,
    /// Σω (y − mean)(y − mean)ᵀ.
    pub scatter: Sym3,
}

impl SuffStats {
    /// The statistics of the union of two data sets (Chan et al.'s pairwise update).
    pub fn combine(&self, other: &SuffStats) -> SuffStats {
        if !(other.weight > 0.0) {
            return *self;
        }
        if !(self.weight > 0.0) {
            return *other;
        }
        let n = self.weight + other.weight;
        let f = other.weight / n;
        let delta = other.mean - self.mean;
        SuffStats {
            weight: n,
            mean: self.mean + delta * f,
            scatter: self.scatter + other.scatter + Sym3::outer(delta) * (self.weight * f),
        }
    }

    /// The statistics of `self` without the subset `part` (the inverse of [`SuffStats::combine`]), if
    /// the remainder is a valid data set (positive weight, positive semi-definite scatter).
    pub fn subtract(&self, part: &SuffStats) -> Option<SuffStats> {
        if !(part.weight > 0.0) {
            return Some(*self);
        }
        let n = self.weight - part.weight;
        if !(n > 1e-12 * self.weight) {
            return None;
        }
        let mean = (self.mean * self.weight - part.mean * part.weight) / n;
        let delta = part.mean - mean;
        let scatter =
            self.scatter - part.scatter - Sym3::outer(delta) * (n * part.weight / self.weight);
        let ridge = Sym3::scaled_identity(1e-9 * self.scatter.trace().abs() + f64::MIN_POSITIVE);
        let rest = SuffStats {
            weight: n,
            mean,
            scatter,
        };
        (rest.is_valid() && (scatter + ridge).cholesky().is_some()).then_some(rest)
    }

    /// Every weight multiplied by `f` (the online-EM decay).
    pub fn scaled(&self, f: f64) -> SuffStats {
        SuffStats {
            weight: self.weight * f,
            mean: self.mean,
            scatter: self.scatter * f,
        }
    }

    /// True if every number is finite and the weight is not negative.
    pub fn is_valid(&self) -> bool {
        self.weight >= 0.0
            && self.weight.is_finite()
            && self.mean.is_finite()
            && self.scatter.is_finite()
    }
}

/// Parameters of one fit, in the guide's unit frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitParams {
    /// Components k-means++ starts with.
    pub k_init: usize,
    /// Merges and prunes stop here.
    pub k_min: usize,
    /// Splits stop here (≤ [`MAX_COMPONENTS`]).
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

/// The result of one E-step.
#[derive(Clone, Debug)]
pub struct EStep {
    /// Per component: the statistics of the points weighted by their responsibilities.
    pub stats: Vec<SuffStats>,
    /// Per component (only when split evaluation was asked for): the split score and birth cell.
    pub splits: Vec<Option<SplitCandidate>>,
    /// Σ ω ln ρ(y).
    pub log_likelihood: f64,
    /// Σ ω.
    pub weight: f64,
}

/// How badly a component explains its data, and where a child would be born.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitCandidate {
    /// Binned KL divergence (nats) between the component's data and the component, bias-corrected.
    pub divergence: f64,
    /// Effective number of binned points, (Σω)² / Σω².
    pub effective_points: f64,
    /// Share of the binned weight in the birth cell.
    pub birth_share: f64,
    /// Statistics of the points in the birth cell.
    pub birth: SuffStats,
}

/// Structure-of-arrays copy of the components for the vectorisable E-step inner loop.
struct EvalTable {
    mean: [Vec<f64>; 3],
    inv_chol: [Vec<f64>; 6],
    log_coef: Vec<f64>,
}

impl EvalTable {
    /// The table, padded to a multiple of four components (the SIMD width) with dummies of log-weight
    /// −∞, which get responsibility exactly 0 and so change no sum.
    fn new(components: &[Gaussian3], weights: &[f64]) -> Self {
        let padded = components.len().div_ceil(4) * 4;
        let pad = |v: Vec<f64>, fill: f64| {
            let mut v = v;
            v.resize(padded, fill);
            v
        };
        let mean =
            std::array::from_fn(|a| pad(components.iter().map(|g| g.mean()[a]).collect(), 0.0));
        let inv_chol = std::array::from_fn(|i| {
            pad(
                components
                    .iter()
                    .map(|g| g.inverse_cholesky().0[i])
                    .collect(),
                0.0,
            )
        });
        let log_coef = pad(
            components
                .iter()
                .zip(weights)
                .map(|(g, w)| w.ln() + g.log_normalizer())
                .collect(),
            f64::NEG_INFINITY,
        );
        Self {
            mean,
            inv_chol,
            log_coef,
        }
    }

    /// Components including the padding (a multiple of four).
    fn len(&self) -> usize {
        self.log_coef.len()
    }

    /// q_k = ln π_k + ln N_k(y) for every component.
    #[inline]
    fn log_terms(&self, y: DVec3, q: &mut [f64]) {
        let n = q.len();
        let (mx, my, mz) = (&self.mean[0][..n], &self.mean[1][..n], &self.mean[2][..n]);
        let [l00, l10, l11, l20, l21, l22] = &self.inv_chol;
        let (l00, l10, l11) = (&l00[..n], &l10[..n], &l11[..n]);
        let (l20, l21, l22) = (&l20[..n], &l21[..n], &l22[..n]);
        let c = &self.log_coef[..n];
        for k in 0..n {
            let dx = y.x - mx[k];
            let dy = y.y - my[k];
            let dz = y.z - mz[k];
            let z0 = l00[k] * dx;
            let z1 = l10[k].mul_add(dx, l11[k] * dy);
            let z2 = l20[k].mul_add(dx, l21[k].mul_add(dy, l22[k] * dz));
            let m2 = z0.mul_add(z0, z1.mul_add(z1, z2 * z2));
            q[k] = (-0.5f64).mul_add(m2, c[k]);
        }
    }

    /// The split cell of offset d = y − μ_k in component k's whitened frame.
    #[inline]
    fn cell(&self, k: usize, d: DVec3) -> usize {
        let l = |i: usize| self.inv_chol[i][k];
        let z = DVec3::new(
            l(0) * d.x,
            l(1) * d.x + l(2) * d.y,
            l(3) * d.x + l(4) * d.y + l(5) * d.z,
        );
        let bin = |v: f64| (v >= -1.0) as usize + (v >= 0.0) as usize + (v >= 1.0) as usize;
        bin(z.x) + 4 * bin(z.y) + 16 * bin(z.z)
    }
}

/// Probability of each split cell under the standard normal (products of the 1D masses of
/// (−∞, −1), (−1, 0), (0, 1), (1, ∞)).
fn cell_probabilities() -> [f64; CELLS] {
    let tail = norm_cdf(-1.0);
    let p = [tail, 0.5 - tail, 0.5 - tail, tail];
    std::array::from_fn(|c| p[c % 4] * p[(c / 4) % 4] * p[c / 16])
}

/// Per-chunk sums: the ten moment accumulators as structure-of-arrays over components (so the
/// accumulation loop vectorises), the split cells (ten moments per cell) and Σω² per component,
/// Σω ln ρ and Σω.
struct ChunkSums {
    moments: [Vec<f64>; 10],
    cells: Vec<[f64; 10]>,
    weight2: Vec<f64>,
    log_likelihood: f64,
    weight: f64,
}

/// max over `q` with four independent lanes (exact, so the lane order does not matter).
#[inline]
fn lane_max(q: &[f64]) -> f64 {
    let mut m = [f64::NEG_INFINITY; 4];
    let chunks = q.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..4 {
            m[l] = if c[l] > m[l] { c[l] } else { m[l] };
        }
    }
    for &v in rest {
        m[0] = if v > m[0] { v } else { m[0] };
    }
    m[0].max(m[1]).max(m[2].max(m[3]))
}

/// Σ q with four lanes combined in a fixed order (deterministic, and no serial dependency chain).
#[inline]
fn lane_sum(q: &[f64]) -> f64 {
    let mut s = [0.0f64; 4];
    let chunks = q.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..4 {
            s[l] += c[l];
        }
    }
    for &v in rest {
        s[0] += v;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// Adds ω·(1, d, ddᵀ) to ten raw moment accumulators.
#[inline]
pub(crate) fn add_moments(a: &mut [f64; 10], om: f64, d: DVec3) {
    let (ox, oy, oz) = (om * d.x, om * d.y, om * d.z);
    a[0] += om;
    a[1] += ox;
    a[2] += oy;
    a[3] += oz;
    a[4] += ox * d.x;
    a[5] += ox * d.y;
    a[6] += ox * d.z;
    a[7] += oy * d.y;
    a[8] += oy * d.z;
    a[9] += oz * d.z;
}

fn e_chunk(points: &[WeightedPoint], table: &EvalTable, with_cells: bool) -> ChunkSums {
    let k = table.len();
    let mut moments: [Vec<f64>; 10] = std::array::from_fn(|_| vec![0.0f64; k]);
    let mut cells = vec![[0.0f64; 10]; if with_cells { k * CELLS } else { 0 }];
    let mut weight2 = vec![0.0f64; if with_cells { k } else { 0 }];
    let mut q = [0.0f64; MAX_COMPONENTS];
    let q = &mut q[..k];
    let (mx, my, mz) = (
        &table.mean[0][..k],
        &table.mean[1][..k],
        &table.mean[2][..k],
    );
    let mut log_likelihood = 0.0;
    let mut total = 0.0;
    for p in points {
        let y = p.pos();
        let w = p.weight as f64;
        table.log_terms(y, q);
        let max = lane_max(q);
        if !max.is_finite() {
            continue;
        }
        for v in q.iter_mut() {
            let d = *v - max;
            let e = exp_fast(d);
            *v = if d > -RESPONSIBILITY_CUTOFF { e } else { 0.0 };
        }
        let sum = lane_sum(q);
        log_likelihood += w * (max + sum.ln());
        total += w;
        let scale = w / sum;
        {
            let [s0, s1, s2, s3, s4, s5, s6, s7, s8, s9] = &mut moments;
            let (s0, s1, s2, s3, s4) = (
                &mut s0[..k],
                &mut s1[..k],
                &mut s2[..k],
                &mut s3[..k],
                &mut s4[..k],
            );
            let (s5, s6, s7, s8, s9) = (
                &mut s5[..k],
                &mut s6[..k],
                &mut s7[..k],
                &mut s8[..k],
                &mut s9[..k],
            );
            for i in 0..k {
                let om = q[i] * scale;
                let dx = y.x - mx[i];
                let dy = y.y - my[i];
                let dz = y.z - mz[i];
                let (ox, oy, oz) = (om * dx, om * dy, om * dz);
                s0[i] += om;
                s1[i] += ox;
                s2[i] += oy;
                s3[i] += oz;
                s4[i] = ox.mul_add(dx, s4[i]);
                s5[i] = ox.mul_add(dy, s5[i]);
                s6[i] = ox.mul_add(dz, s6[i]);
                s7[i] = oy.mul_add(dy, s7[i]);
                s8[i] = oy.mul_add(dz, s8[i]);
                s9[i] = oz.mul_add(dz, s9[i]);
            }
        }
        if with_cells {
            let inv = 1.0 / sum;
            for i in 0..k {
                if q[i] * inv > CELL_MIN_RESPONSIBILITY {
                    let om = q[i] * scale;
                    let d = y - DVec3::new(mx[i], my[i], mz[i]);
                    add_moments(&mut cells[i * CELLS + table.cell(i, d)], om, d);
                    weight2[i] += om * om;
                }
            }
        }
    }
    ChunkSums {
        moments,
        cells,
        weight2,
        log_likelihood,
        weight: total,
    }
}

/// One E-step over all points (parallel over fixed chunks, reduced in chunk order), optionally binning
/// every component's data for the split criterion.
pub fn e_step(
    points: &[WeightedPoint],
    components: &[Gaussian3],
    weights: &[f64],
    evaluate_splits: bool,
) -> EStep {
    let table = EvalTable::new(components, weights);
    let k = components.len();
    let mut moments = vec![[0.0f64; 10]; k];
    let mut cells = vec![[0.0f64; 10]; if evaluate_splits { k * CELLS } else { 0 }];
    let mut weight2 = vec![0.0f64; k];
    let mut log_likelihood = 0.0;
    let mut weight = 0.0;
    let chunks: Vec<&[WeightedPoint]> = points.chunks(E_CHUNK).collect();
    for round in chunks.chunks(CHUNKS_PER_ROUND) {
        let parts: Vec<ChunkSums> = round
            .par_iter()
            .map(|chunk| e_chunk(chunk, &table, evaluate_splits))
            .collect();
        for part in &parts {
            for (i, m) in moments.iter_mut().enumerate() {
                for (j, v) in m.iter_mut().enumerate() {
                    *v += part.moments[j][i];
                }
            }
            for (c, p) in cells.iter_mut().zip(&part.cells) {
                for (a, b) in c.iter_mut().zip(p) {
                    *a += b;
                }
            }
            for (a, b) in weight2.iter_mut().zip(&part.weight2) {
                *a += b;
            }
            log_likelihood += part.log_likelihood;
            weight += part.weight;
        }
    }
    let stats = moments
        .iter()
        .zip(components)
        .map(|(m, g)| raw_to_stats(m, g.mean()))
        .collect();
    let probabilities = cell_probabilities();
    let splits = (0..k)
        .map(|i| {
            if !evaluate_splits {
                return None;
            }
            let cells = &cells[i * CELLS..(i + 1) * CELLS];
            split_candidate(cells, weight2[i], &probabilities, components[i].mean())
        })
        .collect();
    EStep {
        stats,
        splits,
        log_likelihood,
        weight,
    }
}

/// The binned divergence and birth cell of one component (see the module notes).
fn split_candidate(
    cells: &[[f64; 10]],
    weight2: f64,
    probabilities: &[f64; CELLS],
    reference: DVec3,
) -> Option<SplitCandidate> {
    let n: f64 = cells.iter().map(|c| c[0]).sum();
    if !(n > 0.0 && weight2 > 0.0) {
        return None;
    }
    let mut divergence = 0.0;
    let mut best = (0.0, None);
    for (c, (cell, p)) in cells.iter().zip(probabilities).enumerate() {
        let o = cell[0] / n;
        if o > 0.0 {
            let term = o * (o / p).ln();
            divergence += term;
            if o > *p && term > best.0 {
                best = (term, Some(c));
            }
        }
    }
    let effective_points = n * n / weight2;
    let divergence = divergence - (CELLS as f64 - 1.0) / (2.0 * effective_points);
    let c = best.1?;
    Some(SplitCandidate {
        divergence,
        effective_points,
        birth_share: cells[c][0] / n,
        birth: raw_to_stats(&cells[c], reference),
    })
}

/// Moment-form statistics from sums relative to `reference`.
fn raw_to_stats(a: &[f64; 10], reference: DVec3) -> SuffStats {
    let n = a[0];
    if !(n > 0.0) {
        return SuffStats {
            weight: 0.0,
            mean: reference,
            scatter: Sym3::ZERO,
        };
    }
    let s1 = DVec3::new(a[1], a[2], a[3]);
    let s2 = Sym3([a[4], a[5], a[6], a[7], a[8], a[9]]);
    let scatter = s2 - Sym3::outer(s1) * (1.0 / n);
    // Rounding can leave a tiny negative diagonal when all points coincide.
    let mut m = scatter.0;
    for i in [0, 3, 5] {
        m[i] = m[i].max(0.0);
    }
    SuffStats {
        weight: n,
        mean: reference + s1 / n,
        scatter: Sym3(m),
    }
}

/// The MAP Gaussian of `stats` under the covariance prior with pseudo-weight `nu`; `fallback` if that
/// fails (non-finite data), and its mean if the component has no data.
fn map_gaussian(stats: &SuffStats, nu: f64, params: &FitParams, fallback: &Gaussian3) -> Gaussian3 {
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

/// A small deterministic generator for the initialisation (SplitMix64).
struct SplitMix(u64);

impl SplitMix {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Weighted k-means++ seeding and Lloyd iterations on a stride subset of `points`; returns the
/// clusters' statistics (empty clusters dropped).
pub fn kmeans_init(points: &[WeightedPoint], k: usize, seed: u64) -> Vec<SuffStats> {
    let stride = points.len().div_ceil(INIT_SAMPLE).max(1);
    let sample: Vec<(DVec3, f64)> = points
        .iter()
        .step_by(stride)
        .map(|p| (p.pos(), p.weight as f64))
        .filter(|(_, w)| *w > 0.0)
        .collect();
    let k = k.min(sample.len());
    if k == 0 {
        return Vec::new();
    }
    let mut rng = SplitMix(seed);
    let total: f64 = sample.iter().map(|(_, w)| w).sum();
    let Some((first, _, _)) = pick_interval(sample.iter().map(|(_, w)| *w), rng.unit() * total)
    else {
        return Vec::new();
    };
    let mut centers = vec![sample[first].0];
    let mut d2: Vec<f64> = sample
        .iter()
        .map(|(y, _)| y.distance_squared(centers[0]))
        .collect();
    while centers.len() < k {
        let total: f64 = sample.iter().zip(&d2).map(|((_, w), d)| w * d).sum();
        if !(total > 0.0) {
            break;
        }
        let weights = sample.iter().zip(&d2).map(|((_, w), d)| w * d);
        let Some((next, _, _)) = pick_interval(weights, rng.unit() * total) else {
            break;
        };
        let c = sample[next].0;
        for (d, (y, _)) in d2.iter_mut().zip(&sample) {
            *d = d.min(y.distance_squared(c));
        }
        centers.push(c);
    }
    let nearest = |y: DVec3, centers: &[DVec3]| {
        let mut best = (f64::INFINITY, 0);
        for (j, c) in centers.iter().enumerate() {
            let d = y.distance_squared(*c);
            if d < best.0 {
                best = (d, j);
            }
        }
        best.1
    };
    for _ in 0..LLOYD_ITERATIONS {
        let mut sums = vec![(DVec3::ZERO, 0.0f64); centers.len()];
        for (y, w) in &sample {
            let j = nearest(*y, &centers);
            sums[j].0 += (*y - centers[j]) * *w;
            sums[j].1 += w;
        }
        for (c, (s, w)) in centers.iter_mut().zip(&sums) {
            if *w > 0.0 {
                *c += *s / *w;
            }
        }
    }
    let mut acc = vec![[0.0f64; 10]; centers.len()];
    for (y, w) in &sample {
        let j = nearest(*y, &centers);
        let d = *y - centers[j];
        let a = &mut acc[j];
        a[0] += w;
        a[1] += w * d.x;
        a[2] += w * d.y;
        a[3] += w * d.z;
        a[4] += w * d.x * d.x;
        a[5] += w * d.x * d.y;
        a[6] += w * d.x * d.z;
        a[7] += w * d.y * d.y;
        a[8] += w * d.y * d.z;
        a[9] += w * d.z * d.z;
    }
    acc.iter()
        .zip(&centers)
        .map(|(a, c)| raw_to_stats(a, *c))
        .filter(|s| s.weight > 0.0)
        .collect()
}

/// A component during the structure step.
struct Entry {
    component: Gaussian3,
    /// This update's statistics.
    fresh: SuffStats,
    /// The decayed statistics of earlier updates.
    previous: SuffStats,
    split: Option<SplitCandidate>,
    touched: bool,
}

impl Entry {
    fn blended(&self) -> SuffStats {
        self.previous.combine(&self.fresh)
    }
}

/// Splits an entry by birth from its best cell (see the module notes), if the parts are valid.
fn birth_split(
    e: &Entry,
    birth: &SuffStats,
) -> Option<((SuffStats, SuffStats), (SuffStats, SuffStats))> {
    let fresh_rest = e.fresh.subtract(birth)?;
    let share = e.previous.weight / e.fresh.weight;
    let history = (share > 0.0 && share.is_finite())
        .then(|| {
            let part = birth.scaled(share);
            e.previous.subtract(&part).map(|rest| (part, rest))
        })
        .flatten()
        .unwrap_or((
            SuffStats {
                weight: 0.0,
                mean: birth.mean,
                scatter: Sym3::ZERO,
            },
            e.previous,
        ));
    Some(((*birth, fresh_rest), history))
}

/// Merges, prunes and splits (see the module notes).
fn restructure(entries: &mut Vec<Entry>, params: &FitParams, report: &mut FitReport) {
    let total_of = |entries: &[Entry]| entries.iter().map(|e| e.blended().weight).sum::<f64>();
    // Merges.
    while entries.len() > params.k_min.max(1) {
        let mut best = (f64::INFINITY, 0, 0);
        for i in 0..entries.len() {
            if entries[i].touched {
                continue;
            }
            for j in i + 1..entries.len() {
                if entries[j].touched {
                    continue;
                }
                let d = entries[i].component.bhattacharyya(&entries[j].component);
                if d < best.0 {
                    best = (d, i, j);
                }
            }
        }
        let (d, i, j) = best;
        if !(d < params.merge_threshold) {
            break;
        }
        let other = entries.remove(j);
        let nu = params.prior_strength * total_of(entries);
        let e = &mut entries[i];
        e.fresh = e.fresh.combine(&other.fresh);
        e.previous = e.previous.combine(&other.previous);
        e.component = map_gaussian(&e.blended(), nu, params, &e.component);
        e.split = None;
        e.touched = true;
        report.merges += 1;
    }
    // Prunes.
    let total = total_of(entries);
    while entries.len() > params.k_min.max(1) {
        let (i, w) = entries
            .iter()
            .enumerate()
            .map(|(i, e)| (i, e.blended().weight))
            .fold((0, f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b });
        if !(w < params.prune_share * total) {
            break;
        }
        entries.remove(i);
        report.prunes += 1;
    }
    // Splits, best first.
    let total = total_of(entries);
    if !(total > 0.0) {
        return;
    }
    let mut candidates: Vec<(f64, usize)> = entries
        .iter()
        .enumerate()
        .filter(|(_, e)| !e.touched)
        .filter_map(|(i, e)| {
            let s = e.split?;
            let score = e.blended().weight / total * s.divergence;
            (s.effective_points >= MIN_SPLIT_POINTS
                && s.birth_share >= MIN_BIRTH_SHARE
                && score > params.split_threshold)
                .then_some((score, i))
        })
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let nu = params.prior_strength * total;
    for (_, i) in candidates {
        if entries.len() >= params.k_max {
            break;
        }
        let Some(split) = entries[i].split else {
            continue;
        };
        let Some(((fresh_child, fresh_rest), (prev_child, prev_rest))) =
            birth_split(&entries[i], &split.birth)
        else {
            continue;
        };
        let parent = entries[i].component;
        let make = |fresh: SuffStats, previous: SuffStats| {
            let blended = previous.combine(&fresh);
            Entry {
                component: map_gaussian(&blended, nu, params, &parent),
                fresh,
                previous,
                split: None,
                touched: true,
            }
        };
        entries[i] = make(fresh_rest, prev_rest);
        entries.push(make(fresh_child, prev_child));
        report.splits += 1;
    }
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
