//! Where each component's training rays start: a density over the origins of the rays a component
//! explains, so that a shading point x chooses among the components by how much of the contribution
//! leaving the neighbourhood of x went through each, rather than by their global weights.
//!
//! The mixture ρ(y) = Σ π_k N_k(y) is the marginal over all shading points of where contribution-carrying
//! rays pass. From a given x only some of those places matter: a door gap gathers the paths of the room
//! behind it, not those of the room in front; each lamp's shade, the walls it lights. With the origin
//! model the weight of component k at x is
//!
//! c_k(x) = (1 − β) W_k O_k(x) / Σ_j W_j O_j(x) + β π_k,
//!
//! where W_k is the share of the rays' contribution aimed at component k (the posterior
//! γ_k ∝ π_k ∫ N_k(o + tω) t² dt of the ray's direction among the components' directional pdfs, over
//! the ray's clipped interval: [`NarrowingTable::line_posterior`]) and O_k a density fitted to their
//! origins. Σ_k c_k(x) = 1, so the directional pdf Σ_k c_k(x) ∫ N_k(x + tω) t² dt stays exact and
//! normalised: c_k depends on x only. O_k is a Student-t density with one degree of freedom,
//! O_k(x) = (1 + d²)⁻² / (π² |S_k|^½), d² = (x − m_k)ᵀ S_k⁻¹ (x − m_k): the origins of lines through a
//! point thin out as 1/r², far more slowly than a Gaussian's tail (which made distant but valid shading
//! points all but ignore a focus), and it needs no exponential. m_k and S_k are the weighted mean and
//! covariance of the origins, S_k times `spread` and floored at `min_sigma`. β keeps every component
//! reachable from everywhere.

use glam::DVec3;
use rayon::prelude::*;

use super::columns::GaussianColumns;
use super::em::add_moments;
use super::gaussian::Gaussian3;
use super::mixture::Mixture;
use super::rays::{stride_pick, NarrowingTable, TrainingRay};
use super::sym3::Sym3;

/// Rays per work item of the origin fit (fixed, so the chunk sums and their order do not depend on the
/// thread count).
const ORIGIN_CHUNK: usize = 2048;

/// Parameters of the origin fit ([`fit_origins`]), in the guide's unit frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OriginParams {
    /// β: the share of the global weights π_k kept at every shading point.
    pub floor: f64,
    /// Factor on each origin covariance, giving the scale matrix S_k (a component's rays start from a
    /// region, not from the few thousand points that showed it).
    pub spread: f64,
    /// Least scale of an origin density along any axis (unit frame).
    pub min_sigma: f64,
    /// Most rays used per fit (a deterministic stride subset beyond it).
    pub max_rays: usize,
}

/// Per component of a mixture, the density of its rays' origins and its share of their contribution,
/// with β ([`OriginParams::floor`]): the x-dependent component weights c_k(x) of the module notes.
#[derive(Clone, Debug, PartialEq)]
pub struct OriginModel {
    gaussians: Vec<Gaussian3>,
    shares: Vec<f64>,
    floor: f64,
    /// W_k times the normaliser of O_k, padded with 0.
    coef: Vec<f64>,
    mean: [Vec<f64>; 3],
    inv_chol: [Vec<f64>; 6],
}

impl OriginModel {
    /// The model of per-component origin Gaussians `gaussians`, contribution shares `shares` (≥ 0, not
    /// all 0; normalised here) and floor β in [0, 1].
    pub fn new(gaussians: Vec<Gaussian3>, shares: &[f64], floor: f64) -> Result<Self, String> {
        if gaussians.len() != shares.len() {
            return Err(format!(
                "{} origin shares for {} origin Gaussians",
                shares.len(),
                gaussians.len()
            ));
        }
        if !(0.0..=1.0).contains(&floor) {
            return Err(format!("origin floor must lie in [0, 1], got {floor}"));
        }
        if shares.iter().any(|s| !(*s >= 0.0 && s.is_finite())) {
            return Err("origin shares must be finite and not negative".into());
        }
        let sum: f64 = shares.iter().sum();
        if !(sum > 0.0) {
            return Err("origin shares sum to 0".into());
        }
        // Shares that already sum to 1 are kept bit for bit (a snapshot reloads the same model).
        let shares: Vec<f64> = if (sum - 1.0).abs() <= 1e-9 {
            shares.to_vec()
        } else {
            shares.iter().map(|s| s / sum).collect()
        };
        Ok(Self::with_normalized(gaussians, shares, floor))
    }

    fn with_normalized(gaussians: Vec<Gaussian3>, shares: Vec<f64>, floor: f64) -> Self {
        let padded = gaussians.len().div_ceil(8) * 8;
        // W_k times the normaliser 1/(π² |S_k|^½) of the ν = 1 Student-t density.
        let mut coef: Vec<f64> = gaussians
            .iter()
            .zip(&shares)
            .map(|(g, s)| {
                let det_sqrt = g.cholesky().0[0] * g.cholesky().0[2] * g.cholesky().0[5];
                s / (std::f64::consts::PI * std::f64::consts::PI * det_sqrt)
            })
            .collect();
        coef.resize(padded, 0.0);
        let GaussianColumns { mean, inv_chol, .. } = GaussianColumns::new(&gaussians, padded);
        Self {
            mean,
            inv_chol,
            coef,
            gaussians,
            shares,
            floor,
        }
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.gaussians.len()
    }

    /// True without components.
    pub fn is_empty(&self) -> bool {
        self.gaussians.is_empty()
    }

    /// Location m_k and scale matrix S_k of each O_k (as the mean and covariance of a [`Gaussian3`]).
    pub fn gaussians(&self) -> &[Gaussian3] {
        &self.gaussians
    }

    /// The contribution shares W_k (summing to 1).
    pub fn shares(&self) -> &[f64] {
        &self.shares
    }

    /// β.
    pub fn floor(&self) -> f64 {
        self.floor
    }

    /// Writes c_k(x)/π_k for every component into `out` ([`OriginModel`] padded length: a multiple of
    /// eight), given 1/π_k padded with zeros (the padding gets β, harmless beside its zero weight).
    /// No exponentials: the loops vectorise.
    #[inline]
    pub fn factors(&self, x: DVec3, inv_weights: &[f64], out: &mut [f64]) {
        let n = self.coef.len();
        let out = &mut out[..n];
        let inv_weights = &inv_weights[..n];
        let (mx, my, mz) = (&self.mean[0][..n], &self.mean[1][..n], &self.mean[2][..n]);
        let [l0, l1, l2, l3, l4, l5] = &self.inv_chol;
        let (l0, l1, l2, l3, l4, l5) = (&l0[..n], &l1[..n], &l2[..n], &l3[..n], &l4[..n], &l5[..n]);
        let c = &self.coef[..n];
        for k in 0..n {
            let (dx, dy, dz) = (x.x - mx[k], x.y - my[k], x.z - mz[k]);
            let z0 = l0[k] * dx;
            let z1 = l1[k].mul_add(dx, l2[k] * dy);
            let z2 = l3[k].mul_add(dx, l4[k].mul_add(dy, l5[k] * dz));
            let t = 1.0 / (1.0 + z0.mul_add(z0, z1.mul_add(z1, z2 * z2)));
            out[k] = c[k] * t * t;
        }
        let mut sums = [0.0f64; 8];
        for block in out.chunks_exact(8) {
            for (s, v) in sums.iter_mut().zip(block) {
                *s += v;
            }
        }
        let sum = ((sums[0] + sums[1]) + (sums[2] + sums[3]))
            + ((sums[4] + sums[5]) + (sums[6] + sums[7]));
        if !(sum > 0.0 && sum.is_finite()) {
            // Not a finite point: the global weights.
            out.fill(1.0);
            return;
        }
        let scale = (1.0 - self.floor) / sum;
        let floor = self.floor;
        for (f, iw) in out.iter_mut().zip(inv_weights) {
            *f = (*f * scale).mul_add(*iw, floor);
        }
    }

    /// The same model with every Gaussian mapped by `map` (a change of units).
    pub(crate) fn mapped(&self, map: impl Fn(&Gaussian3) -> Option<Gaussian3>) -> Option<Self> {
        let gaussians = self.gaussians.iter().map(map).collect::<Option<Vec<_>>>()?;
        Some(Self::with_normalized(
            gaussians,
            self.shares.clone(),
            self.floor,
        ))
    }
}

/// Fits the origin model of `mixture` (unit frame) to `rays`: every ray's contribution is divided
/// among the components by its line posterior, and each component's share of it, with the rays'
/// origins, makes its origin Gaussian (see the module notes). `None` without rays or components, or if
/// no ray's line reaches a component. Deterministic for any thread count.
pub fn fit_origins(
    rays: &[TrainingRay],
    mixture: &Mixture,
    params: &OriginParams,
) -> Option<OriginModel> {
    let k = mixture.len();
    if k == 0 || rays.is_empty() {
        return None;
    }
    let table = NarrowingTable::new(mixture, 1.0);
    let stride = rays.len().div_ceil(params.max_rays.max(1)).max(1);
    let count = rays.len().div_ceil(stride);
    let chunks = count.div_ceil(ORIGIN_CHUNK);
    let parts: Vec<Vec<[f64; 10]>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut acc = vec![[0.0f64; 10]; k];
            let mut gamma = [0.0f64; super::mixture::MAX_COMPONENTS];
            for m in c * ORIGIN_CHUNK..((c + 1) * ORIGIN_CHUNK).min(count) {
                let index = stride_pick(m, stride, 0);
                let Some(ray) = rays.get(index) else {
                    continue;
                };
                let o = ray.origin_f64();
                let d = DVec3::from_array(ray.direction.map(|v| v as f64));
                let w = ray.weight as f64;
                let usable = w > 0.0 && w.is_finite();
                if !usable || !table.line_posterior(o, d, ray.t0 as f64, ray.t1 as f64, &mut gamma)
                {
                    continue;
                }
                for (a, g) in acc.iter_mut().zip(&gamma[..k]) {
                    if *g > 0.0 {
                        // Unit frame, so |o| ≲ 1 and the raw moments need no centring.
                        add_moments(a, w * g, o);
                    }
                }
            }
            acc
        })
        .collect();
    let mut acc = vec![[0.0f64; 10]; k];
    for part in &parts {
        for (a, p) in acc.iter_mut().zip(part) {
            for (x, y) in a.iter_mut().zip(p) {
                *x += y;
            }
        }
    }
    let mut pooled = [0.0f64; 10];
    for a in &acc {
        for (x, y) in pooled.iter_mut().zip(a) {
            *x += y;
        }
    }
    if !(pooled[0] > 0.0 && pooled[0].is_finite()) {
        return None;
    }
    let floor = Sym3::scaled_identity(params.min_sigma * params.min_sigma);
    let gaussian = |a: &[f64; 10]| {
        let w = a[0];
        let mean = DVec3::new(a[1], a[2], a[3]) / w;
        let second = Sym3([a[4], a[5], a[6], a[7], a[8], a[9]]) * (1.0 / w);
        // The floor also covers the rounding of E[ooᵀ] − E[o]E[o]ᵀ (|o| ≲ 1 in the unit frame).
        let cov = second - Sym3::outer(mean) + floor;
        Gaussian3::new(mean, cov * params.spread.max(1.0))
    };
    // A component no ray reached gets the origins of all rays, with share 0 (β alone).
    let all = gaussian(&pooled)?;
    let gaussians: Vec<Gaussian3> = acc
        .iter()
        .map(|a| {
            if a[0] > 1e-12 * pooled[0] {
                gaussian(a).unwrap_or(all)
            } else {
                all
            }
        })
        .collect();
    let shares: Vec<f64> = acc
        .iter()
        .map(|a| if a[0] > 1e-12 * pooled[0] { a[0] } else { 0.0 })
        .collect();
    OriginModel::new(gaussians, &shares, params.floor).ok()
}
