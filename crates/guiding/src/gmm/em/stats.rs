//! Weighted statistics in moment form: what EM accumulates per component and keeps across updates.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::gmm::sym3::Sym3;

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

/// Adds ω·(1, d, ddᵀ) to ten raw moment accumulators.
#[inline]
pub(super) fn add_moments(a: &mut [f64; 10], om: f64, d: DVec3) {
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

/// Moment-form statistics from sums relative to `reference`.
pub(super) fn raw_to_stats(a: &[f64; 10], reference: DVec3) -> SuffStats {
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
