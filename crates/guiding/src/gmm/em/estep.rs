//! The E-step: every point's responsibilities, the statistics they weigh, and (in the structure
//! iteration) each component's binned divergence from its data, the split criterion.

use glam::DVec3;
use rayon::prelude::*;

use super::stats::{add_moments, raw_to_stats, SuffStats};
use crate::gmm::gaussian::Gaussian3;
use crate::gmm::mixture::MAX_COMPONENTS;
use crate::gmm::rays::WeightedPoint;
use crate::gmm::special::{exp_fast, norm_cdf};

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
