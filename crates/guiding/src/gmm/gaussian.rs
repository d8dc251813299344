//! A 3D full-covariance Gaussian with its Cholesky factor and the precomputed quantities the hot loops
//! (directional pdf, E-step) need, all in `f64`.

use glam::DVec3;

use super::special::LN_SQRT_2PI;
use super::sym3::{Lower3, Sym3};

/// N(μ, Σ) with Σ = L Lᵀ. Immutable: every derived quantity is computed once by [`Gaussian3::new`], so
/// two Gaussians built from the same (μ, Σ) are bit-identical (snapshots rely on this).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gaussian3 {
    mean: DVec3,
    cov: Sym3,
    chol: Lower3,
    inv_chol: Lower3,
    log_norm: f64,
    norm: f64,
}

impl Gaussian3 {
    /// N(`mean`, `cov`), or `None` if an input is not finite, `cov` is not positive definite, or the
    /// normaliser (2π)^−3/2 |Σ|^−1/2 is not representable (|Σ| below e^−1400).
    pub fn new(mean: DVec3, cov: Sym3) -> Option<Self> {
        if !mean.is_finite() {
            return None;
        }
        let chol = cov.cholesky()?;
        let inv_chol = chol.inverse();
        if !inv_chol.0.iter().all(|v| v.is_finite()) {
            return None;
        }
        let log_norm = -3.0 * LN_SQRT_2PI - chol.log_diagonal_sum();
        (log_norm.is_finite() && log_norm < 700.0).then(|| Self {
            mean,
            cov,
            chol,
            inv_chol,
            log_norm,
            norm: log_norm.exp(),
        })
    }

    /// μ.
    #[inline]
    pub fn mean(&self) -> DVec3 {
        self.mean
    }

    /// Σ.
    #[inline]
    pub fn covariance(&self) -> Sym3 {
        self.cov
    }

    /// L with Σ = L Lᵀ.
    #[inline]
    pub fn cholesky(&self) -> &Lower3 {
        &self.chol
    }

    /// L⁻¹ (so that |L⁻¹(y − μ)|² is the Mahalanobis distance).
    #[inline]
    pub fn inverse_cholesky(&self) -> &Lower3 {
        &self.inv_chol
    }

    /// ln of the normaliser, −(3/2) ln 2π − ½ ln |Σ|.
    #[inline]
    pub fn log_normalizer(&self) -> f64 {
        self.log_norm
    }

    /// The normaliser (2π)^−3/2 |Σ|^−1/2 = N(μ | μ, Σ).
    #[inline]
    pub fn normalizer(&self) -> f64 {
        self.norm
    }

    /// (y − μ)ᵀ Σ⁻¹ (y − μ).
    #[inline]
    pub fn mahalanobis_sq(&self, y: DVec3) -> f64 {
        self.inv_chol.mul_vec(y - self.mean).length_squared()
    }

    /// ln N(y | μ, Σ).
    #[inline]
    pub fn log_density(&self, y: DVec3) -> f64 {
        self.log_norm - 0.5 * self.mahalanobis_sq(y)
    }

    /// N(y | μ, Σ).
    #[inline]
    pub fn density(&self, y: DVec3) -> f64 {
        self.log_density(y).exp()
    }

    /// μ + L z: maps a standard normal vector to a sample.
    #[inline]
    pub fn point(&self, z: DVec3) -> DVec3 {
        self.mean + self.chol.mul_vec(z)
    }

    /// The Gaussian of (y − `center`) / `scale` for y ~ self (a change of units), `None` if degenerate.
    pub fn transformed(&self, center: DVec3, scale: f64) -> Option<Self> {
        Gaussian3::new(
            (self.mean - center) / scale,
            self.cov * (1.0 / (scale * scale)),
        )
    }

    /// The Gaussian of `center` + `scale`·y for y ~ self (the inverse of [`Gaussian3::transformed`]).
    pub fn untransformed(&self, center: DVec3, scale: f64) -> Option<Self> {
        Gaussian3::new(center + self.mean * scale, self.cov * (scale * scale))
    }

    /// Bhattacharyya distance to `other`: ⅛ Δμᵀ Σ̄⁻¹ Δμ + ½ ln(|Σ̄| / √(|Σ₁||Σ₂|)), Σ̄ = (Σ₁ + Σ₂)/2.
    pub fn bhattacharyya(&self, other: &Gaussian3) -> f64 {
        let avg = (self.cov + other.cov) * 0.5;
        let Some(l) = avg.cholesky() else {
            return f64::INFINITY;
        };
        let z = l.inverse().mul_vec(other.mean - self.mean);
        let log_det_avg = 2.0 * l.log_diagonal_sum();
        let log_det_1 = 2.0 * self.chol.log_diagonal_sum();
        let log_det_2 = 2.0 * other.chol.log_diagonal_sum();
        0.125 * z.length_squared() + 0.5 * (log_det_avg - 0.5 * (log_det_1 + log_det_2))
    }
}
