//! Opt-in reweightings of an update's training rays that have not shown a gain yet (the `experimental`
//! cargo feature; `docs/experiments/2026-12-06-clamped-training-weights.md`). Both keep each mixture's
//! total mass, so they change the shape of the fit, never its scale.

use serde::{Deserialize, Serialize};

use super::rays::{effective_count, TrainingRay};

/// The experiments' parameters; the defaults leave the weights alone.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ExperimentalConfig {
    /// β of tempered training weights: each update's rays are fitted with c^β instead of c, rescaled
    /// so that each mixture's total mass is unchanged (1 fits c as Rath et al. do). Below 1 a few heavy
    /// rays (a caustic's fireflies) no longer decide the fit alone.
    pub weight_power: f64,
    /// Clamp each update's heaviest training rays (per mixture) so that at least this many rays stand
    /// behind the fit by weight, (Σm)²/Σm² over the masses m = c·length (fewer if there are fewer
    /// rays), keeping the total mass; 0 leaves the weights alone.
    pub min_effective_rays: f64,
}

impl Default for ExperimentalConfig {
    fn default() -> Self {
        Self {
            weight_power: 1.0,
            min_effective_rays: 0.0,
        }
    }
}

impl ExperimentalConfig {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.weight_power > 0.0 && self.weight_power <= 1.0) {
            return Err(format!(
                "experimental.weight_power must lie in (0, 1], got {}",
                self.weight_power
            ));
        }
        if !(self.min_effective_rays >= 0.0 && self.min_effective_rays.is_finite()) {
            return Err(format!(
                "experimental.min_effective_rays must be finite and >= 0, got {}",
                self.min_effective_rays
            ));
        }
        Ok(())
    }

    /// Reweights one mixture's rays of an update: tempering, then clamping.
    pub fn reweight(&self, rays: &mut [TrainingRay]) {
        if self.weight_power != 1.0 {
            temper_weights(rays, self.weight_power);
        }
        if self.min_effective_rays > 0.0 {
            clamp_to_effective_rays(rays, self.min_effective_rays);
        }
    }
}

/// Replaces every ray's weight c by s·c^β, with s chosen so that the rays' total mass Σ c·length is
/// unchanged.
fn temper_weights(rays: &mut [TrainingRay], beta: f64) {
    reweight_keeping_mass(rays, |c| c.powf(beta));
}

/// Replaces every weight c by s·f(c), s chosen so that the rays' total mass is what it was.
fn reweight_keeping_mass(rays: &mut [TrainingRay], f: impl Fn(f64) -> f64) {
    let before: f64 = rays.iter().map(TrainingRay::mass).sum();
    for r in rays.iter_mut() {
        r.weight = f(r.weight as f64) as f32;
    }
    let after: f64 = rays.iter().map(TrainingRay::mass).sum();
    if after > 0.0 && before.is_finite() {
        let s = before / after;
        for r in rays.iter_mut() {
            r.weight = (r.weight as f64 * s) as f32;
        }
    }
}

/// Clamps the rays' weights at the least bound for which (Σm)²/Σm² over their masses m = c·length
/// reaches `target` (or 0.999 of the ray count, if that is smaller), then rescales them to the total
/// mass they had. The effective count grows as the bound falls, so the bound is found by bisection
/// on its logarithm.
fn clamp_to_effective_rays(rays: &mut [TrainingRay], target: f64) {
    let target = target.min(0.999 * rays.len() as f64);
    let effective = |cap: f64| {
        effective_count(
            rays.iter()
                .map(|r| (r.weight as f64).min(cap) * (r.t1 - r.t0) as f64),
        )
    };
    let max_weight = rays.iter().map(|r| r.weight as f64).fold(0.0, f64::max);
    if !(max_weight > 0.0 && max_weight.is_finite()) || effective(max_weight) >= target {
        return;
    }
    let min_weight = rays
        .iter()
        .map(|r| r.weight as f64)
        .fold(f64::INFINITY, f64::min);
    let (mut lo, mut hi) = (min_weight.ln(), max_weight.ln());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if effective(mid.exp()) >= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let cap = lo.exp();
    reweight_keeping_mass(rays, |c| c.min(cap));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rays(weights: &[f32]) -> Vec<TrainingRay> {
        weights
            .iter()
            .enumerate()
            .map(|(i, &w)| TrainingRay {
                origin: [0.0; 3],
                direction: [1.0, 0.0, 0.0],
                t0: 0.0,
                t1: 1.0 + (i % 3) as f32,
                weight: w,
                pdf: 1.0,
            })
            .collect()
    }

    fn effective(rays: &[TrainingRay]) -> f64 {
        effective_count(rays.iter().map(TrainingRay::mass))
    }

    fn total(rays: &[TrainingRay]) -> f64 {
        rays.iter().map(TrainingRay::mass).sum()
    }

    #[test]
    fn clamping_reaches_the_effective_ray_count_and_keeps_the_mass() {
        let mut weights = vec![1.0f32; 99];
        weights.extend([5e3, 2e3, 700.0]);
        let mut r = rays(&weights);
        let (before_mass, before_eff) = (total(&r), effective(&r));
        assert!(before_eff < 5.0, "{before_eff}");
        clamp_to_effective_rays(&mut r, 30.0);
        let after = effective(&r);
        assert!((after - 30.0).abs() < 1e-3, "{after}");
        assert!((total(&r) / before_mass - 1.0).abs() < 1e-5);
        // The light rays keep their relative weights; the heavy ones share one bound.
        assert_eq!(r[0].weight, r[1].weight);
        assert_eq!(r[99].weight, r[101].weight);
        assert!(r[99].weight > r[0].weight);
    }

    #[test]
    fn clamping_leaves_well_supported_or_single_rays_alone() {
        let weights: Vec<f32> = (0..200).map(|i| 1.0 + (i % 7) as f32).collect();
        let mut r = rays(&weights);
        let before = r.clone();
        clamp_to_effective_rays(&mut r, 30.0);
        assert_eq!(r, before);
        let mut one = rays(&[1e6]);
        clamp_to_effective_rays(&mut one, 100.0);
        assert_eq!(one, rays(&[1e6]));
    }

    #[test]
    fn clamping_few_rays_equalises_their_weights() {
        let mut r = rays(&[1e-3, 1.0, 1e4]);
        let mass = total(&r);
        clamp_to_effective_rays(&mut r, 100.0);
        assert!(r.iter().all(|r| r.weight.is_finite() && r.weight > 0.0));
        assert!((total(&r) / mass - 1.0).abs() < 1e-5);
        // At most as many effective rays as there are; the bound falls to the lightest ray.
        assert!(effective(&r) <= 3.0);
        assert!((r[1].weight / r[2].weight - 1.0).abs() < 1e-4);
    }

    #[test]
    fn tempering_takes_the_power_and_keeps_the_mass() {
        let mut r = rays(&[1.0, 4.0, 16.0]);
        let mass = total(&r);
        temper_weights(&mut r, 0.5);
        assert!((total(&r) / mass - 1.0).abs() < 1e-6);
        assert!((r[1].weight / r[0].weight - 2.0).abs() < 1e-5);
        assert!((r[2].weight / r[0].weight - 4.0).abs() < 1e-5);
    }

    #[test]
    fn the_defaults_leave_the_weights_alone() {
        let mut r = rays(&[1.0, 4.0, 16.0]);
        let before = r.clone();
        ExperimentalConfig::default().reweight(&mut r);
        assert_eq!(r, before);
    }
}
