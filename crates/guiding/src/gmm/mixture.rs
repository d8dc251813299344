//! A weighted mixture of 3D Gaussians: the spatial density ρ(y) = Σ_k π_k N(y | μ_k, Σ_k), its exact
//! directional pdf and point sampling.

use glam::{DVec3, Vec3};

use super::columns::GaussianColumns;
use super::directional_pdf::{half_line_kernel, half_line_kernel_f32};
use super::gaussian::Gaussian3;
use super::special::{inv_norm_cdf_approx, norm_cdf_branchless, open_unit};
use super::special32::norm_cdf_f32_given_u;

/// Most components one mixture may hold (bounds the stack buffers of the sampling and E-step loops).
pub const MAX_COMPONENTS: usize = 128;
/// Lanes of the component loops: arrays are padded to a multiple of it with inert components.
const LANES: usize = 8;
/// `f32` values per component that [`Mixture::prepare_vertex`] writes for a shading point.
pub const TERMS_PER_COMPONENT: usize = 4;
/// Tolerance on Σπ = 1 for mixtures whose weights are taken as given (snapshots, M-step output).
const WEIGHT_SUM_TOLERANCE: f64 = 1e-9;

/// ρ(y) = Σ_k π_k N(y | μ_k, Σ_k) with Σπ_k = 1 (or no components at all: the empty mixture).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mixture {
    weights: Vec<f64>,
    components: Vec<Gaussian3>,
    cdf: Vec<f64>,
    soa: Soa,
}

/// Structure-of-arrays copies of the components for the vectorised pdf and hemisphere-mass loops,
/// padded to a multiple of [`LANES`] with inert components of coefficient 0.
#[derive(Clone, Debug, Default, PartialEq)]
struct Soa {
    /// π_k N₀_k.
    coef: Vec<f64>,
    /// π_k.
    weight: Vec<f64>,
    mean: [Vec<f64>; 3],
    inv_chol: [Vec<f64>; 6],
    chol: [Vec<f64>; 6],
    /// π_k N₀_k in `f32`, for the renderer's kernel.
    coef32: Vec<f32>,
    /// The rows of L⁻¹ in `f32`, for the renderer's kernel.
    inv_chol32: [Vec<f32>; 6],
    /// The rows of L in `f32`, for the hemisphere masses.
    chol32: [Vec<f32>; 6],
}

impl Soa {
    fn new(weights: &[f64], components: &[Gaussian3]) -> Self {
        let padded = components.len().div_ceil(LANES) * LANES;
        let GaussianColumns {
            mean,
            inv_chol,
            chol,
        } = GaussianColumns::new(components, padded);
        let mut coef: Vec<f64> = weights
            .iter()
            .zip(components)
            .map(|(w, g)| w * g.normalizer())
            .collect();
        coef.resize(padded, 0.0);
        let mut weight = weights.to_vec();
        weight.resize(padded, 0.0);
        let to_f32 = |v: &Vec<f64>| v.iter().map(|x| *x as f32).collect::<Vec<f32>>();
        Self {
            chol32: std::array::from_fn(|i| to_f32(&chol[i])),
            coef32: to_f32(&coef),
            inv_chol32: std::array::from_fn(|i| to_f32(&inv_chol[i])),
            coef,
            weight,
            mean,
            inv_chol,
            chol,
        }
    }
}

impl Mixture {
    /// The mixture with no components (ρ = 0).
    pub fn empty() -> Self {
        Self::default()
    }

    /// A mixture with weights proportional to `weights` (normalised here).
    pub fn new(weights: &[f64], components: Vec<Gaussian3>) -> Result<Self, String> {
        let sum: f64 = weights.iter().sum();
        if !(sum > 0.0 && sum.is_finite()) {
            return Err(format!(
                "mixture weights must have a positive finite sum, got {sum}"
            ));
        }
        let normalised: Vec<f64> = weights.iter().map(|w| w / sum).collect();
        Self::from_normalized(normalised, components)
    }

    /// A mixture whose weights already sum to 1 (within 1e-9) and are used bit for bit.
    pub fn from_normalized(weights: Vec<f64>, components: Vec<Gaussian3>) -> Result<Self, String> {
        if weights.len() != components.len() {
            return Err(format!(
                "{} mixture weights for {} components",
                weights.len(),
                components.len()
            ));
        }
        if components.len() > MAX_COMPONENTS {
            return Err(format!(
                "a mixture holds at most {MAX_COMPONENTS} components, got {}",
                components.len()
            ));
        }
        if let Some(w) = weights.iter().find(|w| !(**w > 0.0 && **w <= 1.0)) {
            return Err(format!("mixture weight {w} is not in (0, 1]"));
        }
        let sum: f64 = weights.iter().sum();
        if !components.is_empty() && (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE {
            return Err(format!("mixture weights sum to {sum}, not 1"));
        }
        let mut acc = 0.0;
        let cdf = weights
            .iter()
            .map(|w| {
                acc += w;
                acc
            })
            .collect();
        let soa = Soa::new(&weights, &components);
        Ok(Self {
            weights,
            components,
            cdf,
            soa,
        })
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// True if the mixture has no components.
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// The weights π_k.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The components.
    pub fn components(&self) -> &[Gaussian3] {
        &self.components
    }

    /// ρ(y).
    pub fn density(&self, y: DVec3) -> f64 {
        self.weights
            .iter()
            .zip(&self.components)
            .map(|(w, g)| w * g.density(y))
            .sum()
    }

    /// The exact solid-angle pdf of ω = normalize(y − x), y ~ ρ, at unit `omega`:
    /// Σ_k π_k ∫₀^∞ N_k(x + tω) t² dt (vectorised over components, summed in four fixed lanes).
    #[inline]
    pub fn directional_pdf(&self, x: DVec3, omega: DVec3) -> f64 {
        let s = &self.soa;
        let n = s.coef.len();
        let (mx, my, mz) = (&s.mean[0][..n], &s.mean[1][..n], &s.mean[2][..n]);
        let [l0, l1, l2, l3, l4, l5] = &s.inv_chol;
        let (l0, l1, l2, l3, l4, l5) = (&l0[..n], &l1[..n], &l2[..n], &l3[..n], &l4[..n], &l5[..n]);
        let coef = &s.coef[..n];
        let mut values = [0.0f64; MAX_COMPONENTS];
        let values = &mut values[..n];
        for k in 0..n {
            let d = [mx[k] - x.x, my[k] - x.y, mz[k] - x.z];
            let l = [l0[k], l1[k], l2[k], l3[k], l4[k], l5[k]];
            values[k] = coef[k] * half_line_kernel(d, l, omega);
        }
        let mut lanes = [0.0f64; 4];
        // Padded to eight, so also to four.
        for block in values.chunks_exact(4) {
            for (acc, v) in lanes.iter_mut().zip(block) {
                *acc += v;
            }
        }
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
    }

    /// The component count rounded up to the loops' lane count: the length of the per-component
    /// buffers that [`Mixture::half_space_masses`] and [`Mixture::prepare_vertex`] fill.
    pub fn padded_len(&self) -> usize {
        self.soa.coef.len()
    }

    /// Writes what the renderer's kernel needs of shading point `x` for every component, in one pass
    /// over the components: into `terms` (which needs [`TERMS_PER_COMPONENT`] × [`Mixture::padded_len`]
    /// values) the whitened offset zd = L⁻¹(μ − x) and ½|zd|², computed in `f64` and stored in `f32` as
    /// four blocks; with `half_space` = (n, upper), into `masses` ([`Mixture::padded_len`] values)
    /// π_k·P_k(n·(y − x) > 0) (or < 0 if not `upper`), the offset along n in `f64` and Φ (to about
    /// 3e-7 relative) in `f32` (see [`Mixture::half_space_masses`] for the `f64` reference).
    #[inline]
    pub fn prepare_vertex(
        &self,
        x: DVec3,
        half_space: Option<(DVec3, bool)>,
        terms: &mut [f32],
        masses: &mut [f64],
    ) {
        let s = &self.soa;
        let n = s.coef.len();
        let (zd0, rest) = terms[..TERMS_PER_COMPONENT * n].split_at_mut(n);
        let (zd1, rest) = rest.split_at_mut(n);
        let (zd2, half_c) = rest.split_at_mut(n);
        let (mx, my, mz) = (&s.mean[0][..n], &s.mean[1][..n], &s.mean[2][..n]);
        let [l0, l1, l2, l3, l4, l5] = &s.inv_chol;
        let (l0, l1, l2, l3, l4, l5) = (&l0[..n], &l1[..n], &l2[..n], &l3[..n], &l4[..n], &l5[..n]);
        let (normal, sign) = match half_space {
            Some((normal, upper)) => (normal, if upper { 1.0 } else { -1.0 }),
            None => (DVec3::ZERO, 1.0),
        };
        let mut delta = [0.0f32; MAX_COMPONENTS];
        let delta = &mut delta[..n];
        for k in 0..n {
            let d = [mx[k] - x.x, my[k] - x.y, mz[k] - x.z];
            let z0 = l0[k] * d[0];
            let z1 = l1[k].mul_add(d[0], l2[k] * d[1]);
            let z2 = l3[k].mul_add(d[0], l4[k].mul_add(d[1], l5[k] * d[2]));
            zd0[k] = z0 as f32;
            zd1[k] = z1 as f32;
            zd2[k] = z2 as f32;
            half_c[k] = (0.5 * z0.mul_add(z0, z1.mul_add(z1, z2 * z2))) as f32;
            delta[k] = (sign * (normal.x * d[0] + normal.y * d[1] + normal.z * d[2])) as f32;
        }
        if half_space.is_some() {
            self.masses_from_offsets(normal.as_vec3(), delta, masses);
        }
    }

    /// The renderer's directional pdf (see [`Mixture::directional_pdf`], the `f64` reference it
    /// agrees with to about 1e-6 relative; see `half_line_kernel_f32` for the bound) at unit `omega`
    /// from the shading point whose [`Mixture::prepare_vertex`] terms are `terms`: `f32` eight lanes wide, summed
    /// in eight fixed lanes.
    #[inline]
    pub fn directional_pdf_prepared(&self, terms: &[f32], omega: [f32; 3]) -> f32 {
        let s = &self.soa;
        let n = s.coef.len();
        let (zd0, rest) = terms[..TERMS_PER_COMPONENT * n].split_at(n);
        let (zd1, rest) = rest.split_at(n);
        let (zd2, half_c) = rest.split_at(n);
        let [l0, l1, l2, l3, l4, l5] = &s.inv_chol32;
        let (l0, l1, l2, l3, l4, l5) = (&l0[..n], &l1[..n], &l2[..n], &l3[..n], &l4[..n], &l5[..n]);
        let coef = &s.coef32[..n];
        let mut values = [0.0f32; MAX_COMPONENTS];
        let values = &mut values[..n];
        for k in 0..n {
            values[k] = coef[k]
                * half_line_kernel_f32(
                    [zd0[k], zd1[k], zd2[k]],
                    half_c[k],
                    [l0[k], l1[k], l2[k], l3[k], l4[k], l5[k]],
                    omega,
                );
        }
        let mut lanes = [0.0f32; LANES];
        for block in values.chunks_exact(LANES) {
            for (acc, v) in lanes.iter_mut().zip(block) {
                *acc += v;
            }
        }
        ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3]))
            + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]))
    }

    /// Writes π_k·P_k(n·(y − x) > 0) (or < 0 if `upper` is false) for every component into `out`, all in
    /// `f64` (the reference for the masses of [`Mixture::prepare_vertex`]; `out` needs
    /// [`Mixture::padded_len`] entries).
    #[inline]
    pub fn half_space_masses(&self, x: DVec3, n: DVec3, upper: bool, out: &mut [f64]) {
        let s = &self.soa;
        let len = s.coef.len();
        let out = &mut out[..len];
        let (mx, my, mz) = (&s.mean[0][..len], &s.mean[1][..len], &s.mean[2][..len]);
        let [c0, c1, c2, c3, c4, c5] = &s.chol;
        let (c0, c1, c2) = (&c0[..len], &c1[..len], &c2[..len]);
        let (c3, c4, c5) = (&c3[..len], &c4[..len], &c5[..len]);
        let weights = &s.weight[..len];
        let sign = if upper { 1.0 } else { -1.0 };
        for k in 0..len {
            let delta = n.x * (mx[k] - x.x) + n.y * (my[k] - x.y) + n.z * (mz[k] - x.z);
            // |Lᵀn| = √(nᵀΣn).
            let t0 = c0[k] * n.x + c1[k] * n.y + c3[k] * n.z;
            let t1 = c2[k] * n.y + c4[k] * n.z;
            let t2 = c5[k] * n.z;
            let sigma = (t0 * t0 + t1 * t1 + t2 * t2).sqrt();
            out[k] = weights[k] * norm_cdf_branchless(sign * delta / sigma);
        }
    }

    /// π_k·Φ(δ_k/σ_k) into `out` from the signed offsets δ_k along the unit normal `n`
    /// (σ_k = √(nᵀΣ_kn)), in `f32` eight lanes wide, with one division per component.
    #[inline]
    fn masses_from_offsets(&self, n: Vec3, delta: &[f32], out: &mut [f64]) {
        let s = &self.soa;
        let len = s.coef.len();
        let out = &mut out[..len];
        let delta = &delta[..len];
        let [c0, c1, c2, c3, c4, c5] = &s.chol32;
        let (c0, c1, c2) = (&c0[..len], &c1[..len], &c2[..len]);
        let (c3, c4, c5) = (&c3[..len], &c4[..len], &c5[..len]);
        let weights = &s.weight[..len];
        let mut cdf = [0.0f32; MAX_COMPONENTS];
        let cdf = &mut cdf[..len];
        for k in 0..len {
            // |Lᵀn| = √(nᵀΣn).
            let t0 = c0[k].mul_add(n.x, c1[k].mul_add(n.y, c3[k] * n.z));
            let t1 = c2[k].mul_add(n.y, c4[k] * n.z);
            let t2 = c5[k] * n.z;
            let var = t0.mul_add(t0, t1.mul_add(t1, t2 * t2));
            let sigma = var.sqrt();
            // k = δ/σ and u = 4/(|k| + 4) = 4σ/(|δ| + 4σ) from one reciprocal.
            let reach = delta[k].abs() + 4.0 * sigma;
            let inv = 1.0 / (sigma * reach);
            let u = 4.0 * var * inv;
            cdf[k] = norm_cdf_f32_given_u(delta[k] * reach * inv, u);
        }
        for k in 0..len {
            out[k] = weights[k] * cdf[k] as f64;
        }
    }

    /// Picks component k with probability π_k using `u` in [0, 1) and returns it with `u` rescaled to
    /// [0, 1) within the chosen interval (reusable as a fresh uniform).
    #[inline]
    pub fn select(&self, u: f64) -> Option<(usize, f64)> {
        let last = self.components.len().checked_sub(1)?;
        let k = self.cdf[..last].partition_point(|&c| c <= u);
        let lo = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let rescaled = ((u - lo) / self.weights[k]).clamp(0.0, 1.0);
        Some((k, rescaled))
    }

    /// A point y ~ ρ from three uniforms: `u[0]` selects the component and, rescaled, drives the first
    /// normal variate; all three normal variates are inverse-CDF transforms (to 1e-9, see
    /// [`inv_norm_cdf_approx`]).
    pub fn sample_point(&self, u: [f64; 3]) -> Option<DVec3> {
        let (k, u0) = self.select(u[0])?;
        let z = DVec3::new(
            inv_norm_cdf_approx(open_unit(u0)),
            inv_norm_cdf_approx(open_unit(u[1])),
            inv_norm_cdf_approx(open_unit(u[2])),
        );
        Some(self.components[k].point(z))
    }

    /// The same density in other units: every component mapped by y ↦ (y − `center`)/`scale`.
    pub fn transformed(&self, center: DVec3, scale: f64) -> Result<Self, String> {
        let components = self
            .components
            .iter()
            .map(|g| g.transformed(center, scale))
            .collect::<Option<Vec<_>>>()
            .ok_or("a component degenerates under the change of units")?;
        Self::from_normalized(self.weights.clone(), components)
    }

    /// The inverse of [`Mixture::transformed`]: every component mapped by y ↦ `center` + `scale`·y.
    pub fn untransformed(&self, center: DVec3, scale: f64) -> Result<Self, String> {
        let components = self
            .components
            .iter()
            .map(|g| g.untransformed(center, scale))
            .collect::<Option<Vec<_>>>()
            .ok_or("a component degenerates under the change of units")?;
        Self::from_normalized(self.weights.clone(), components)
    }
}
