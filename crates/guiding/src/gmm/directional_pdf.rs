//! The exact directional pdf of "sample y ~ N(μ, Σ), go towards y": the Gaussian restricted to the
//! half-line x + tω, integrated with the solid-angle Jacobian t² (`docs/design/gmm.md`, "Sampling and the
//! exact directional pdf").
//!
//! Along the line, N(x + tω) = exp(ln c − (t − m)²/(2s²)) with, for P = Σ⁻¹ and d = μ − x,
//! s² = 1/(ωᵀPω), m = s² ωᵀPd and ln c = ln N₀ − ½(dᵀPd − m²/s²). Everything is computed from the
//! whitened vectors L⁻¹ω and L⁻¹d, so the quadratic forms are sums of squares (never negative) and the
//! perpendicular term dᵀPd − m²/s² is a Cauchy–Schwarz gap clamped at 0.

use glam::DVec3;

use super::gaussian::Gaussian3;
use super::special::{exp_fast, half_line_h_branchless, norm_interval_fast, SQRT_2PI};
use super::special32::{exp_f32, half_line_h_f32, EXP_F32_MIN, SQRT_2PI_F32};

/// A 3D Gaussian restricted to the line x + tω: exp(`log_peak` − (t − `m`)²/(2`s`²)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineGaussian {
    /// Position of the peak along the line.
    pub m: f64,
    /// Standard deviation along the line.
    pub s: f64,
    /// ln of the 3D density at the peak.
    pub log_peak: f64,
    /// ln of the 3D density at t = 0 (the line's origin x); equals `log_peak` − ½(m/s)².
    pub log_at_origin: f64,
}

impl LineGaussian {
    /// m/s, the signed distance of the peak from the origin in units of s.
    #[inline]
    pub fn alpha(&self) -> f64 {
        self.m / self.s
    }

    /// ∫_{t0}^{t1} N(x + tω) dt, the Gaussian's mass on a segment of the line (per unit cross-section).
    #[inline]
    pub fn segment_mass(&self, t0: f64, t1: f64) -> f64 {
        if !(t1 > t0) || self.log_peak < -745.0 {
            return 0.0;
        }
        let a = (t0 - self.m) / self.s;
        let b = (t1 - self.m) / self.s;
        self.log_peak.exp() * self.s * SQRT_2PI * norm_interval_fast(a, b)
    }
}

impl Gaussian3 {
    /// This Gaussian restricted to the line x + tω (ω need not be normalised; t is then in units of |ω|).
    #[inline]
    pub fn along_line(&self, x: DVec3, omega: DVec3) -> LineGaussian {
        let l = self.inverse_cholesky();
        let zw = l.mul_vec(omega);
        let zd = l.mul_vec(self.mean() - x);
        let a = zw.length_squared();
        let b = zw.dot(zd);
        let c = zd.length_squared();
        let inv_sqrt_a = 1.0 / a.sqrt();
        let alpha = b * inv_sqrt_a;
        let perp = (c - alpha * alpha).max(0.0);
        LineGaussian {
            m: b / a,
            s: inv_sqrt_a,
            log_peak: self.log_normalizer() - 0.5 * perp,
            log_at_origin: self.log_normalizer() - 0.5 * c,
        }
    }

    /// The exact solid-angle pdf at unit direction `omega` from `x` of ω = normalize(y − x), y ~ self:
    /// ∫₀^∞ N(x + tω) t² dt = c s³ G(m/s), G(α) = √(2π)(1 + α²)Φ(α) + α e^{−α²/2}.
    ///
    /// G is evaluated without erfc and without cancellation through H (see
    /// [`super::special::half_line_h`]): for α ≤ 0 (the half-line points away from the mean) c e^{−α²/2}
    /// is the density at x, N₀ e^{−dᵀPd/2}, times H(−α); for α > 0, G = √(2π)(1 + α²) − e^{−α²/2}H(α).
    /// All exponents are ≤ 0.23; a factor below e^−700 makes the component 0.
    #[inline]
    pub fn directional_pdf(&self, x: DVec3, omega: DVec3) -> f64 {
        let l = &self.inverse_cholesky().0;
        let m = self.mean();
        self.normalizer()
            * half_line_kernel(
                [m.x - x.x, m.y - x.y, m.z - x.z],
                [l[0], l[1], l[2], l[3], l[4], l[5]],
                omega,
            )
    }
}

/// ∫₀^∞ N(x + tω) t² dt / N₀ for one component given d = μ − x and the rows of L⁻¹, branch-free so loops
/// over components vectorise (see [`Gaussian3::directional_pdf`] for the formula): s³ e^{−c/2} H(|α|)
/// for α ≤ 0, s³ e^{−perp/2}(√(2π)(1 + α²) − e^{−α²/2} H(α)) for α > 0, and 0 when the Gaussian factor
/// is below e^−700.
#[inline(always)]
pub(crate) fn half_line_kernel(d: [f64; 3], l: [f64; 6], w: DVec3) -> f64 {
    let zw0 = l[0] * w.x;
    let zw1 = l[1].mul_add(w.x, l[2] * w.y);
    let zw2 = l[3].mul_add(w.x, l[4].mul_add(w.y, l[5] * w.z));
    let zd0 = l[0] * d[0];
    let zd1 = l[1].mul_add(d[0], l[2] * d[1]);
    let zd2 = l[3].mul_add(d[0], l[4].mul_add(d[1], l[5] * d[2]));
    let a = zw0.mul_add(zw0, zw1.mul_add(zw1, zw2 * zw2));
    let b = zw0.mul_add(zd0, zw1.mul_add(zd1, zw2 * zd2));
    let c = zd0.mul_add(zd0, zd1.mul_add(zd1, zd2 * zd2));
    let inv_sqrt_a = 1.0 / a.sqrt();
    let alpha = b * inv_sqrt_a;
    let s3 = inv_sqrt_a * inv_sqrt_a * inv_sqrt_a;
    let h = half_line_h_branchless(alpha.abs());
    let half_a2 = 0.5 * alpha * alpha;
    let half_perp = 0.5 * (c - alpha * alpha).max(0.0);
    let half_c = 0.5 * c;
    let away = alpha <= 0.0;
    let exponent = if away { half_c } else { half_perp };
    let gaussian = exp_fast(-exponent);
    let toward = SQRT_2PI * alpha.mul_add(alpha, 1.0) - exp_fast(-half_a2) * h;
    let g = if away { h } else { toward };
    if exponent > 700.0 {
        0.0
    } else {
        s3 * gaussian * g
    }
}

/// [`half_line_kernel`] in `f32` for the renderer's hot loop, given the whitened offset zd = L⁻¹(μ − x)
/// and ½|zd|² computed in `f64` once per shading point, the rows of L⁻¹ and the unit direction `w`.
///
/// The squared distance of the mean from the line is |zd × zw|²/|zw|² rather than c − α², which in
/// `f32` would cancel catastrophically for small, distant components (|zd| ~ 1e3). What remains is the
/// rounding of zd and ω to `f32`: a relative pdf error of about 6e-8·|zd|·√perp, the same order as the
/// pdf's own change when ω moves by one `f32` ulp. Returns 0 where the Gaussian factor is below e^−87.
#[inline(always)]
pub(crate) fn half_line_kernel_f32(zd: [f32; 3], half_c: f32, l: [f32; 6], w: [f32; 3]) -> f32 {
    let zw0 = l[0] * w[0];
    let zw1 = l[1].mul_add(w[0], l[2] * w[1]);
    let zw2 = l[3].mul_add(w[0], l[4].mul_add(w[1], l[5] * w[2]));
    let a = zw0.mul_add(zw0, zw1.mul_add(zw1, zw2 * zw2));
    let b = zw0.mul_add(zd[0], zw1.mul_add(zd[1], zw2 * zd[2]));
    let inv_sqrt_a = 1.0 / a.sqrt();
    let inv_a = inv_sqrt_a * inv_sqrt_a;
    let alpha = b * inv_sqrt_a;
    let x0 = zd[1].mul_add(zw2, -(zd[2] * zw1));
    let x1 = zd[2].mul_add(zw0, -(zd[0] * zw2));
    let x2 = zd[0].mul_add(zw1, -(zd[1] * zw0));
    let half_perp = 0.5 * x0.mul_add(x0, x1.mul_add(x1, x2 * x2)) * inv_a;
    let s3 = inv_a * inv_sqrt_a;
    let h = half_line_h_f32(alpha.abs());
    let away = alpha <= 0.0;
    let exponent = if away { half_c } else { half_perp };
    let toward = SQRT_2PI_F32 * alpha.mul_add(alpha, 1.0) - exp_f32(-0.5 * alpha * alpha) * h;
    let g = if away { h } else { toward };
    let value = s3 * exp_f32(-exponent) * g;
    // `!(≤)` also rejects a NaN exponent (an overflowed distance), whose value would be NaN.
    if !(exponent <= -EXP_F32_MIN) {
        0.0
    } else {
        value
    }
}
