//! Truncated Gaussian sampling: the 1D truncated standard normal by inverse CDF (used for hemisphere
//! truncation and for drawing points along training rays), and a 3D Gaussian conditioned on one side of
//! a plane (`docs/design/gmm.md`, "Hemisphere truncation").

use glam::DVec3;

use super::gaussian::Gaussian3;
use super::special::{
    inv_norm_cdf, inv_norm_cdf_approx, norm_cdf, norm_cdf_fast, norm_interval, norm_sf,
};

/// The standard normal conditioned on (a, b), a < b (either may be infinite), by inverse CDF of `u`
/// in [0, 1). Monotone in `u`. The quantile is taken on the side of the median the result falls on
/// (Φ from below, Φ(−x) from above), so both tails keep their relative accuracy; an interval whose
/// mass underflows returns its finite end nearest the bulk.
pub fn truncated_std_normal(a: f64, b: f64, u: f64) -> f64 {
    let mass = norm_interval(a, b);
    if !(mass > 0.0) {
        return if a >= 0.0 {
            a
        } else if b <= 0.0 {
            b
        } else {
            0.0
        };
    }
    let below = norm_cdf(a) + u * mass;
    let x = if below <= 0.5 {
        inv_norm_cdf(below)
    } else {
        -inv_norm_cdf(norm_sf(b) + (1.0 - u) * mass)
    };
    x.clamp(a, b)
}

/// An orthonormal pair perpendicular to unit `n` (Duff et al. 2017, branchless up to the sign).
pub fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Where the plane (x, n) cuts a Gaussian: the offset δ = n·(μ − x) and σₙ = √(nᵀΣn) = |Lᵀn|.
#[inline]
fn plane_offset(g: &Gaussian3, x: DVec3, n: DVec3) -> (f64, DVec3) {
    (n.dot(g.mean() - x), g.cholesky().mul_transpose_vec(n))
}

/// Probability that y ~ `g` lies strictly above the plane through `x` with unit normal `n`
/// (n·(y − x) > 0), or below it if `upper` is false.
#[inline]
pub fn half_space_mass(g: &Gaussian3, x: DVec3, n: DVec3, upper: bool) -> f64 {
    let (delta, ltn) = plane_offset(g, x, n);
    let sigma = ltn.length();
    let k = delta / sigma;
    norm_cdf_fast(if upper { k } else { -k })
}

/// A sample of `g` conditioned on the half-space n·(y − x) > 0 (`upper`) or < 0, from three uniforms.
///
/// With y = μ + L z, the constraint only involves w = e·z for e = Lᵀn/|Lᵀn|, which is a standard normal
/// independent of the rest of z: w is drawn from the truncated normal with `u[0]`, the two components of
/// z perpendicular to e from `u[1]`, `u[2]` by inverse CDF (Acklam's, to 1e-9: see
/// [`inv_norm_cdf_approx`]).
pub fn sample_half_space(g: &Gaussian3, x: DVec3, n: DVec3, upper: bool, u: [f64; 3]) -> DVec3 {
    let (delta, ltn) = plane_offset(g, x, n);
    let sigma = ltn.length();
    let e = ltn / sigma;
    let bound = -delta / sigma;
    let w = if upper {
        truncated_std_normal(bound, f64::INFINITY, u[0])
    } else {
        truncated_std_normal(f64::NEG_INFINITY, bound, u[0])
    };
    let (t1, t2) = orthonormal_basis(e);
    let z = e * w + t1 * inv_norm_cdf_approx(u[1]) + t2 * inv_norm_cdf_approx(u[2]);
    g.point(z)
}
