//! The energy a rough dielectric interface lets through, integrated over visible microfacet normals
//! with tensor Gauss-Legendre quadrature (as Mitsuba 3's `eval_transmittance` / `eval_reflectance`), and
//! the table of its external transmittance t(cos θ) that `roughplastic` and `roughcoating` look up.

use super::fresnel::{fresnel_dielectric, reflect_about, refract_about};
use super::microfacet::Microfacet;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Resolution of the external transmittance table (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub(super) const TRANSMITTANCE_RES: usize = 64;

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton iteration on Legendre polynomials).
pub(super) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0f64, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            // p1 = P_n(x), p0 = P_{n-1}(x).
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// Average over visible normals (from `wi`) of `f(m)`, by tensor Gauss-Legendre quadrature.
fn visible_normal_average(
    dist: &Microfacet,
    wi: Vec3,
    nodes: &[(f64, f64)],
    f: impl Fn(Vec3) -> f64,
) -> f64 {
    let mut acc = 0.0;
    for &(x, wx) in nodes {
        for &(y, wy) in nodes {
            let u = Vec2::new((0.5 * x + 0.5) as f32, (0.5 * y + 0.5) as f32);
            let (m, _) = dist.sample(wi, u);
            acc += f(m) * wx * wy;
        }
    }
    acc * 0.25
}

/// Fraction of light from `wi` transmitted through a rough interface of relative IOR `eta`, including
/// the masking of the refracted direction.
pub(super) fn rough_transmittance(
    dist: &Microfacet,
    wi: Vec3,
    eta: f32,
    nodes: &[(f64, f64)],
) -> f64 {
    visible_normal_average(dist, wi, nodes, |m| {
        let fr = fresnel_dielectric(wi.dot(m), eta);
        let wo = refract_about(wi, m, fr.cos_theta_t, fr.eta_ti);
        if wo.z * wi.z >= 0.0 {
            return 0.0;
        }
        (dist.smith_g1(wo, m) * (1.0 - fr.f)) as f64
    })
}

/// Fraction of light from `wi` reflected by a rough interface of relative IOR `eta`.
pub(super) fn rough_reflectance(
    dist: &Microfacet,
    wi: Vec3,
    eta: f32,
    nodes: &[(f64, f64)],
) -> f64 {
    visible_normal_average(dist, wi, nodes, |m| {
        let wo = reflect_about(wi, m);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (dist.smith_g1(wo, m) * fresnel_dielectric(wi.dot(m), eta).f) as f64
    })
}

/// The cosines at which the tables are tabulated (0 is replaced by 1e-6).
pub(super) fn table_cosines() -> Vec<f32> {
    (0..TRANSMITTANCE_RES)
        .map(|i| (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6))
        .collect()
}

/// The direction at cosine `mu` in the xz plane.
pub(super) fn direction_at(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// The external transmittance t(μ) of a rough interface, tabulated at [`TRANSMITTANCE_RES`] cosines
/// and interpolated linearly.
#[derive(Clone, Debug)]
pub(super) struct TransmittanceTable {
    values: Box<[f32; TRANSMITTANCE_RES]>,
}

impl TransmittanceTable {
    /// The table of `dist` (integrated over visible normals whatever its sampling strategy) at
    /// relative IOR `eta` (~260k microfacet samples, in parallel).
    pub(super) fn new(dist: &Microfacet, eta: f32) -> Self {
        let dist = Microfacet {
            sample_visible: true,
            ..*dist
        };
        let nodes = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
        let rows: Vec<f64> = table_cosines()
            .par_iter()
            .map(|&mu| rough_transmittance(&dist, direction_at(mu), eta, &nodes))
            .collect();
        Self::from_values(&rows)
    }

    /// A table from its values at [`table_cosines`].
    pub(super) fn from_values(rows: &[f64]) -> Self {
        let mut values = Box::new([0.0f32; TRANSMITTANCE_RES]);
        for (t, row) in values.iter_mut().zip(rows) {
            *t = *row as f32;
        }
        TransmittanceTable { values }
    }

    /// t at cos θ = `mu` (clamped to [0, 1]).
    #[inline]
    pub(super) fn eval(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0) * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x as usize).min(TRANSMITTANCE_RES - 2);
        let t = x - i as f32;
        self.values[i] * (1.0 - t) + self.values[i + 1] * t
    }
}
