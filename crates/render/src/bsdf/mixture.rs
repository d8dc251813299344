//! Weighted sum of BSDFs (Mitsuba 0.6 `mixturebsdf`): f = Σ wᵢ·fᵢ with constant weights. Sampling picks
//! component i with probability pᵢ = wᵢ / Σ w, as Mitsuba 0.6 does; smooth samples report the mixture's
//! pdf Σ pᵢ·pdfᵢ and f/pdf as weight, so MIS sees one consistent density; a delta sample keeps its
//! component's weight scaled by wᵢ/pᵢ. Weights summing to less than one absorb the rest.

use super::{Bsdf, BsdfContext, BsdfSample};
use crate::color::Rgb;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// N nested BSDFs with constant, non-negative weights.
#[derive(Clone, Debug)]
pub struct Mixture {
    /// The components. Shared, so that cloning never duplicates a nested subtree.
    pub bsdfs: Arc<[Bsdf]>,
    /// The weight wᵢ of each component (non-negative, not all zero).
    weights: Box<[f32]>,
    /// Cumulative selection probabilities: `cdf[i]` = Σ_{j≤i} pⱼ, the last one exactly 1.
    cdf: Box<[f32]>,
}

impl Mixture {
    /// A mixture of `bsdfs` with `weights` (the same length, non-negative, positive sum); `None`
    /// otherwise.
    pub fn new(bsdfs: Vec<Bsdf>, weights: Vec<f32>) -> Option<Self> {
        let total: f32 = weights.iter().sum();
        if bsdfs.is_empty()
            || bsdfs.len() != weights.len()
            || weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
            || !(total > 0.0 && total.is_finite())
        {
            return None;
        }
        let mut acc = 0.0;
        let mut cdf: Vec<f32> = weights
            .iter()
            .map(|w| {
                acc += w;
                acc / total
            })
            .collect();
        *cdf.last_mut().expect("non-empty") = 1.0;
        Some(Mixture {
            bsdfs: bsdfs.into(),
            weights: weights.into(),
            cdf: cdf.into(),
        })
    }

    /// The weights wᵢ.
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// The selection probability pᵢ of component `i`.
    #[inline]
    pub fn probability(&self, i: usize) -> f32 {
        self.cdf[i] - if i == 0 { 0.0 } else { self.cdf[i - 1] }
    }

    pub(super) fn eval(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> Rgb {
        self.bsdfs
            .iter()
            .zip(self.weights.iter())
            .filter(|(_, w)| **w > 0.0)
            .fold(Rgb::ZERO, |acc, (b, w)| acc + b.eval(ctx, wi, wo) * *w)
    }

    pub(super) fn pdf(&self, ctx: &BsdfContext, wi: Vec3, wo: Vec3) -> f32 {
        (0..self.bsdfs.len())
            .map(|i| (i, self.probability(i)))
            .filter(|(_, p)| *p > 0.0)
            .map(|(i, p)| self.bsdfs[i].pdf(ctx, wi, wo) * p)
            .sum()
    }

    pub(super) fn sample(
        &self,
        ctx: &BsdfContext,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let i = self
            .cdf
            .partition_point(|&c| c <= u1)
            .min(self.cdf.len() - 1);
        let p = self.probability(i);
        if !(p > 0.0) {
            return None;
        }
        // Reuse u1 within the chosen interval (Mitsuba's `sampleReuse`).
        let lo = self.cdf[i] - p;
        let u1 = ((u1 - lo) / p).clamp(0.0, 1.0 - f32::EPSILON);
        let mut s = self.bsdfs[i].sample(ctx, wi, u1, u2)?;
        if s.delta {
            s.weight *= self.weights[i] / p;
            s.pdf *= p;
            return Some(s);
        }
        let pdf = self.pdf(ctx, wi, s.wo);
        if !(pdf > 0.0) {
            return None;
        }
        s.pdf = pdf;
        s.weight = self.eval(ctx, wi, s.wo) / pdf;
        Some(s)
    }
}
