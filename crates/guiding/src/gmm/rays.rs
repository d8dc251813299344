//! Training rays and the weighted points EM fits to them.
//!
//! A recorded segment becomes one ray per mixture it trains (`docs/design/gmm.md`, "Training rays";
//! `docs/design/octree.md` §3.3): origin x_k, unit direction (ω, or −ω for the diverging mixture), and
//! the interval [t0, t1] of the segment (non-glossy endpoint) or of the whole half-line (glossy
//! endpoint) clipped to the scene box. Rays live in the guide's unit frame (see `guide.rs`), in `f32` to halve the buffer.
//!
//! Points along a ray carry the ray's share of the fitting target, which is a density along the ray:
//! - uniform (before narrowing): c per unit length, so n stratified uniform points of weight c·(t1−t0)/n;
//! - narrowing: the continuous RAY_WEIGHTED splat of the octree, c·P_sel·ρ(x + tω)·t² / p_mix, where
//!   ρ is the mixture the segment was rendered with and P_sel its selection probability (1 − p_div or
//!   p_div). Points are drawn from q(t) = ρ(x + tω) / T on [t0, t1], T = ∫ρ dt (pick component k with
//!   probability π_k I_k / T, I_k its mass on the segment, then t from that component's truncated 1D
//!   Gaussian), so the importance weight c·P_sel·ρ t²/(p_mix·n·q) = c·P_sel·t²·T/(p_mix·n) is free of
//!   ρ(t): the estimator is unbiased for the RAY_WEIGHTED target, with stratified u over the n points.

use glam::DVec3;
use rayon::prelude::*;

use super::cumulative::pick_interval;
use super::directional_pdf::LineGaussian;
use super::mixture::{Mixture, MAX_COMPONENTS};
use super::truncated::truncated_std_normal;

/// Rays per point-generation work item (fixed, so the point order does not depend on the thread count).
pub const RAY_CHUNK: usize = 8192;
/// Components whose upper bound on the segment mass is this many nats below the largest bound are
/// skipped in narrowing (they carry less than e⁻²⁰ ≈ 2e-9 of it, so the proposal and the weights it
/// normalises change by less than 1e-7 even with 64 components).
const NARROWING_CULL: f64 = 20.0;

/// One training ray: origin + t·direction for t in [t0, t1], with the segment's contribution `weight`
/// and the pdf `pdf` its direction ω was sampled with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainingRay {
    /// Origin x_k (unit frame).
    pub origin: [f32; 3],
    /// Unit direction (ω for converging rays, −ω for diverging ones).
    pub direction: [f32; 3],
    /// Start of the clipped interval.
    pub t0: f32,
    /// End of the clipped interval (> t0).
    pub t1: f32,
    /// The segment's contribution c (> 0).
    pub weight: f32,
    /// p_mix(ω) at x_k (> 0).
    pub pdf: f32,
}

impl TrainingRay {
    /// The origin in `f64`.
    pub fn origin_f64(&self) -> DVec3 {
        DVec3::from_array(self.origin.map(|v| v as f64))
    }

    /// The ray's share of the fitting target: its weight times its clipped length.
    pub fn mass(&self) -> f64 {
        self.weight as f64 * (self.t1 - self.t0) as f64
    }
}

/// A point for EM: position (unit frame) and weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedPoint {
    /// Position.
    pub position: [f32; 3],
    /// Weight (> 0).
    pub weight: f32,
}

impl WeightedPoint {
    /// The position in `f64`.
    #[inline]
    pub fn pos(&self) -> DVec3 {
        DVec3::new(
            self.position[0] as f64,
            self.position[1] as f64,
            self.position[2] as f64,
        )
    }
}

/// How points are placed along rays.
#[derive(Clone, Copy, Debug)]
pub enum PointSampling<'a> {
    /// Stratified uniform in t, weight c·length/n.
    Uniform,
    /// Iterative narrowing against the mixture the rays were rendered with.
    Narrowing(&'a NarrowingTable),
}

/// A mixture prepared for narrowing: structure-of-arrays copies of its components (so restricting all
/// of them to a ray vectorises) and, per component, ln π_k + ½ ln tr Σ_k, the ray-independent part of an
/// upper bound on its mass along any line (s ≤ √tr Σ) used to skip negligible components.
#[derive(Clone, Debug)]
pub struct NarrowingTable {
    selection: f64,
    weights: Vec<f64>,
    mean: [Vec<f64>; 3],
    inv_chol: [Vec<f64>; 6],
    log_norm: Vec<f64>,
    log_bound: Vec<f64>,
}

impl NarrowingTable {
    /// The table of `mixture` (unit frame), which the guide selects with probability `selection`.
    pub fn new(mixture: &Mixture, selection: f64) -> Self {
        let comps = mixture.components();
        Self {
            selection,
            weights: mixture.weights().to_vec(),
            mean: std::array::from_fn(|a| comps.iter().map(|g| g.mean()[a]).collect()),
            inv_chol: std::array::from_fn(|i| {
                comps.iter().map(|g| g.inverse_cholesky().0[i]).collect()
            }),
            log_norm: comps.iter().map(|g| g.log_normalizer()).collect(),
            log_bound: mixture
                .weights()
                .iter()
                .zip(comps)
                .map(|(w, g)| w.ln() + 0.5 * g.covariance().trace().ln())
                .collect(),
        }
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// True if the mixture has no components.
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Every component restricted to the line o + tω (as [`super::gaussian::Gaussian3::along_line`],
    /// vectorised): fills `m`, `s`, `log_peak` and the bounds `bound` on the log of each mass on the
    /// segment t ∈ [t0, t1], tightened by the Gaussian factor of the peak's distance outside it, so that
    /// culling against the best bound keeps the components the segment actually passes.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn restrict_to_segment(
        &self,
        o: DVec3,
        w: DVec3,
        t0: f64,
        t1: f64,
        m: &mut [f64],
        s: &mut [f64],
        log_peak: &mut [f64],
        bound: &mut [f64],
    ) {
        let k = self.len();
        let (mx, my, mz) = (&self.mean[0][..k], &self.mean[1][..k], &self.mean[2][..k]);
        let [l00, l10, l11, l20, l21, l22] = &self.inv_chol;
        let (l00, l10, l11) = (&l00[..k], &l10[..k], &l11[..k]);
        let (l20, l21, l22) = (&l20[..k], &l21[..k], &l22[..k]);
        let (ln, lb) = (&self.log_norm[..k], &self.log_bound[..k]);
        let (m, s, log_peak, bound) = (
            &mut m[..k],
            &mut s[..k],
            &mut log_peak[..k],
            &mut bound[..k],
        );
        for i in 0..k {
            let (dx, dy, dz) = (mx[i] - o.x, my[i] - o.y, mz[i] - o.z);
            let zw0 = l00[i] * w.x;
            let zw1 = l10[i] * w.x + l11[i] * w.y;
            let zw2 = l20[i] * w.x + l21[i] * w.y + l22[i] * w.z;
            let zd0 = l00[i] * dx;
            let zd1 = l10[i] * dx + l11[i] * dy;
            let zd2 = l20[i] * dx + l21[i] * dy + l22[i] * dz;
            let a = zw0 * zw0 + zw1 * zw1 + zw2 * zw2;
            let b = zw0 * zd0 + zw1 * zd1 + zw2 * zd2;
            let c = zd0 * zd0 + zd1 * zd1 + zd2 * zd2;
            let inv_sqrt_a = 1.0 / a.sqrt();
            let alpha = b * inv_sqrt_a;
            let perp = (c - alpha * alpha).max(0.0);
            m[i] = b / a;
            s[i] = inv_sqrt_a;
            log_peak[i] = ln[i] - 0.5 * perp;
            let outside = ((t0 - m[i]).max(m[i] - t1)).max(0.0) / s[i];
            bound[i] = log_peak[i] + lb[i];
            bound[i] -= 0.5 * outside * outside;
        }
    }
}

/// The part [t0, t1] of [0, `t_max`] on which origin + t·dir lies in the box [`lo`, `hi`], if non-empty.
pub fn clip_to_box(
    origin: DVec3,
    dir: DVec3,
    t_max: f64,
    lo: DVec3,
    hi: DVec3,
) -> Option<(f64, f64)> {
    let mut t0 = 0.0f64;
    let mut t1 = t_max;
    for axis in 0..3 {
        let (o, d) = (origin[axis], dir[axis]);
        if d == 0.0 {
            if o < lo[axis] || o > hi[axis] {
                return None;
            }
            continue;
        }
        let a = (lo[axis] - o) / d;
        let b = (hi[axis] - o) / d;
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t1 > t0 && t0.is_finite() && t1.is_finite()).then_some((t0, t1))
}

/// SplitMix64 finaliser.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The ray taken from the `m`-th run of `stride` consecutive rays when only one in `stride` is used: a
/// hashed position within the run, so that every ray is taken with probability 1 / `stride` (the
/// subset's weight) and a period in the ray order (bounces of one path, alternating regions) cannot
/// alias with a fixed offset. May point past the end in the last, partial run: the caller skips it.
#[inline]
fn stride_pick(m: usize, stride: usize, seed: u64) -> usize {
    m * stride + (mix64(seed ^ mix64(m as u64)) % stride as u64) as usize
}

/// A uniform number in [0, 1) determined by `key` and `j`.
#[inline]
fn unit_hash(key: u64, j: u64) -> f64 {
    (mix64(key ^ mix64(j)) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Appends the `n` points of one ray (see the module notes), each weight multiplied by `scale`;
/// `key` seeds the ray's stratification jitter.
pub fn ray_points(
    ray: &TrainingRay,
    key: u64,
    n: usize,
    sampling: PointSampling<'_>,
    scale: f64,
    out: &mut Vec<WeightedPoint>,
) {
    let o = ray.origin_f64();
    let d = DVec3::from_array(ray.direction.map(|v| v as f64));
    let (t0, t1) = (ray.t0 as f64, ray.t1 as f64);
    let c = ray.weight as f64 * scale;
    let mut push = |t: f64, w: f64| {
        if w > 0.0 && w.is_finite() {
            let y = o + d * t;
            out.push(WeightedPoint {
                position: y.as_vec3().to_array(),
                weight: w as f32,
            });
        }
    };
    match sampling {
        PointSampling::Uniform => {
            let w = c * (t1 - t0) / n as f64;
            for j in 0..n {
                let u = (j as f64 + unit_hash(key, j as u64)) / n as f64;
                push(t0 + (t1 - t0) * u, w);
            }
        }
        PointSampling::Narrowing(table) => {
            let k = table.len();
            if k == 0 {
                return;
            }
            let mut m = [0.0f64; MAX_COMPONENTS];
            let mut s = [1.0f64; MAX_COMPONENTS];
            let mut log_peak = [f64::NEG_INFINITY; MAX_COMPONENTS];
            let mut bound = [f64::NEG_INFINITY; MAX_COMPONENTS];
            let mut mass = [0.0f64; MAX_COMPONENTS];
            table.restrict_to_segment(o, d, t0, t1, &mut m, &mut s, &mut log_peak, &mut bound);
            let best = bound[..k].iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
            if !(best > -700.0) {
                return;
            }
            let line = |i: usize| LineGaussian {
                m: m[i],
                s: s[i],
                log_peak: log_peak[i],
                log_at_origin: f64::NEG_INFINITY,
            };
            let mut total = 0.0;
            for i in 0..k {
                if bound[i] >= best - NARROWING_CULL {
                    mass[i] = table.weights[i] * line(i).segment_mass(t0, t1);
                    total += mass[i];
                }
            }
            if total < (best - NARROWING_CULL / 2.0).exp() {
                // The likeliest components lie mostly outside the segment: the culled ones may matter.
                total = 0.0;
                for (i, m) in mass[..k].iter_mut().enumerate() {
                    *m = table.weights[i] * line(i).segment_mass(t0, t1);
                    total += *m;
                }
            }
            if !(total > 0.0 && total.is_finite()) {
                return;
            }
            let base = c * table.selection * total / (ray.pdf as f64 * n as f64);
            for j in 0..n {
                let u = (j as f64 + unit_hash(key, j as u64)) / n as f64;
                let target = u * total;
                let Some((i, before, mi)) = pick_interval(mass[..k].iter().copied(), target) else {
                    return;
                };
                let v = ((target - before) / mi).clamp(0.0, 1.0);
                let a = (t0 - m[i]) / s[i];
                let b = (t1 - m[i]) / s[i];
                let t = (m[i] + s[i] * truncated_std_normal(a, b, v)).clamp(t0, t1);
                push(t, base * t * t);
            }
        }
    }
}

/// The points of a ray set: `per_ray` points per ray, on a deterministic stride subset of the rays
/// (weights scaled up by the stride) if that would exceed `max_points`. `seed` keys the jitter.
pub fn generate_points(
    rays: &[TrainingRay],
    per_ray: usize,
    max_points: usize,
    sampling: PointSampling<'_>,
    seed: u64,
) -> Vec<WeightedPoint> {
    if rays.is_empty() || per_ray == 0 {
        return Vec::new();
    }
    let wanted = rays.len().saturating_mul(per_ray);
    let stride = wanted.div_ceil(max_points.max(1)).max(1);
    let count = rays.len().div_ceil(stride);
    let chunks = count.div_ceil(RAY_CHUNK);
    let parts: Vec<Vec<WeightedPoint>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let begin = c * RAY_CHUNK;
            let end = (begin + RAY_CHUNK).min(count);
            let mut out = Vec::with_capacity((end - begin) * per_ray);
            for m in begin..end {
                let index = stride_pick(m, stride, seed);
                let Some(ray) = rays.get(index) else {
                    continue;
                };
                let key = mix64(seed ^ mix64(index as u64));
                ray_points(ray, key, per_ray, sampling, stride as f64, &mut out);
            }
            out
        })
        .collect();
    parts.concat()
}

/// The effective number (Σm)²/Σm² of samples with masses m (0 if all are 0).
pub fn effective_count(masses: impl Iterator<Item = f64>) -> f64 {
    let (s, s2) = masses.fold((0.0f64, 0.0f64), |(s, s2), m| (s + m, s2 + m * m));
    if s2 > 0.0 {
        s * s / s2
    } else {
        0.0
    }
}
