//! Small fixed-size `f64` linear algebra for 3D Gaussians: symmetric matrices (covariances, scatter
//! sums) and lower-triangular Cholesky factors.

use std::ops::{Add, Mul, Sub};

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A symmetric 3×3 matrix stored as its upper triangle `[xx, xy, xz, yy, yz, zz]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sym3(pub [f64; 6]);

impl Sym3 {
    /// The zero matrix.
    pub const ZERO: Sym3 = Sym3([0.0; 6]);

    /// s·I.
    pub fn scaled_identity(s: f64) -> Self {
        Sym3([s, 0.0, 0.0, s, 0.0, s])
    }

    /// diag(d).
    pub fn diagonal(d: DVec3) -> Self {
        Sym3([d.x, 0.0, 0.0, d.y, 0.0, d.z])
    }

    /// v vᵀ.
    pub fn outer(v: DVec3) -> Self {
        Sym3([
            v.x * v.x,
            v.x * v.y,
            v.x * v.z,
            v.y * v.y,
            v.y * v.z,
            v.z * v.z,
        ])
    }

    /// Entry (i, j).
    pub fn at(&self, i: usize, j: usize) -> f64 {
        const INDEX: [[usize; 3]; 3] = [[0, 1, 2], [1, 3, 4], [2, 4, 5]];
        self.0[INDEX[i][j]]
    }

    /// A v.
    pub fn mul_vec(&self, v: DVec3) -> DVec3 {
        let m = &self.0;
        DVec3::new(
            m[0] * v.x + m[1] * v.y + m[2] * v.z,
            m[1] * v.x + m[3] * v.y + m[4] * v.z,
            m[2] * v.x + m[4] * v.y + m[5] * v.z,
        )
    }

    /// vᵀ A v.
    pub fn quad(&self, v: DVec3) -> f64 {
        v.dot(self.mul_vec(v))
    }

    /// Trace.
    pub fn trace(&self) -> f64 {
        self.0[0] + self.0[3] + self.0[5]
    }

    /// Determinant.
    pub fn determinant(&self) -> f64 {
        let [a, b, c, d, e, f] = self.0;
        a * (d * f - e * e) - b * (b * f - c * e) + c * (b * e - c * d)
    }

    /// True if every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }

    /// The Cholesky factor L (A = L Lᵀ), or `None` if A is not (numerically) positive definite.
    pub fn cholesky(&self) -> Option<Lower3> {
        let [a, b, c, d, e, f] = self.0;
        if !self.is_finite() || !(a > 0.0) {
            return None;
        }
        let l00 = a.sqrt();
        let l10 = b / l00;
        let l20 = c / l00;
        let r11 = d - l10 * l10;
        if !(r11 > 0.0) {
            return None;
        }
        let l11 = r11.sqrt();
        let l21 = (e - l20 * l10) / l11;
        let r22 = f - l20 * l20 - l21 * l21;
        if !(r22 > 0.0) {
            return None;
        }
        Some(Lower3([l00, l10, l11, l20, l21, r22.sqrt()]))
    }

    /// Eigenvalues (ascending) and the matching unit eigenvectors, by cyclic Jacobi rotations
    /// (deterministic, accurate for the small and nearly diagonal matrices covariances are).
    pub fn eigen(&self) -> ([f64; 3], [DVec3; 3]) {
        let mut a = [[0.0f64; 3]; 3];
        for (i, row) in a.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.at(i, j);
            }
        }
        let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for _sweep in 0..32 {
            let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
            let scale = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
            if off == 0.0 || off <= 1e-300 || off <= scale * 1e-17 {
                break;
            }
            for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (rp, rq) = (a[p], a[q]);
                a[p] = std::array::from_fn(|k| c * rp[k] - s * rq[k]);
                a[q] = std::array::from_fn(|k| s * rp[k] + c * rq[k]);
                for row in v.iter_mut() {
                    let (vkp, vkq) = (row[p], row[q]);
                    row[p] = c * vkp - s * vkq;
                    row[q] = s * vkp + c * vkq;
                }
            }
        }
        let mut order = [0usize, 1, 2];
        order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
        let values = order.map(|i| a[i][i]);
        let vectors = order.map(|i| DVec3::new(v[0][i], v[1][i], v[2][i]).normalize_or_zero());
        (values, vectors)
    }
}

impl Add for Sym3 {
    type Output = Sym3;
    fn add(self, o: Sym3) -> Sym3 {
        Sym3(std::array::from_fn(|i| self.0[i] + o.0[i]))
    }
}

impl Sub for Sym3 {
    type Output = Sym3;
    fn sub(self, o: Sym3) -> Sym3 {
        Sym3(std::array::from_fn(|i| self.0[i] - o.0[i]))
    }
}

impl Mul<f64> for Sym3 {
    type Output = Sym3;
    fn mul(self, s: f64) -> Sym3 {
        Sym3(self.0.map(|v| v * s))
    }
}

/// A lower-triangular 3×3 matrix stored row by row as `[l00, l10, l11, l20, l21, l22]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lower3(pub [f64; 6]);

impl Lower3 {
    /// L v.
    #[inline]
    pub fn mul_vec(&self, v: DVec3) -> DVec3 {
        let l = &self.0;
        DVec3::new(
            l[0] * v.x,
            l[1] * v.x + l[2] * v.y,
            l[3] * v.x + l[4] * v.y + l[5] * v.z,
        )
    }

    /// Lᵀ v.
    #[inline]
    pub fn mul_transpose_vec(&self, v: DVec3) -> DVec3 {
        let l = &self.0;
        DVec3::new(
            l[0] * v.x + l[1] * v.y + l[3] * v.z,
            l[2] * v.y + l[4] * v.z,
            l[5] * v.z,
        )
    }

    /// L⁻¹ (lower triangular again), for diagonals that are positive.
    pub fn inverse(&self) -> Lower3 {
        let [a, b, c, d, e, f] = self.0;
        Lower3([
            1.0 / a,
            -b / (a * c),
            1.0 / c,
            (b * e - c * d) / (a * c * f),
            -e / (c * f),
            1.0 / f,
        ])
    }

    /// Σ ln l_ii = ½ ln det(L Lᵀ).
    pub fn log_diagonal_sum(&self) -> f64 {
        self.0[0].ln() + self.0[2].ln() + self.0[5].ln()
    }
}
