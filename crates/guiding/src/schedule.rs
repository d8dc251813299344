//! The training schedule both guides share (Rath et al. 2023 §4.3): the statistics of earlier
//! iterations are decayed before each iteration's data is added, and from iteration ⌊2N/3⌋ of N
//! training iterations the data is weighted by "iterative narrowing" (each segment's mass spread along
//! it in proportion to the density that sampled it, rather than uniformly) and the older statistics
//! decay faster.
//!
//! Both guides ask the schedule about the iteration whose data they take: the octree when it splats
//! (before its update) and the mixture when it draws points (in its update). For iteration j's data,
//! [`Schedule::narrows`] says whether it is narrowed and [`Schedule::decay_before`] by what the
//! statistics of the iterations before j are multiplied.

use serde::{Deserialize, Serialize};

/// The decay of the statistics once iterative narrowing starts (the value Rath et al.'s code hard-codes).
pub const NARROWING_DECAY: f64 = 0.25;

/// When narrowing starts and how the statistics decay.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Schedule {
    /// Factor on the statistics of earlier iterations before narrowing starts (afterwards
    /// [`NARROWING_DECAY`]).
    pub decay: f64,
    /// Use iterative narrowing from iteration ⌊`narrowing_start`·N⌋ on.
    pub narrowing: bool,
    /// The share of the N training iterations before narrowing (and its decay) starts (Rath et al.:
    /// 2/3).
    pub narrowing_start: f64,
}

impl Default for Schedule {
    fn default() -> Self {
        Self {
            decay: 0.5,
            narrowing: true,
            narrowing_start: 2.0 / 3.0,
        }
    }
}

impl Schedule {
    /// Checks the ranges; `owner` names the guide in the message.
    pub fn validate(&self, owner: &str) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.decay) {
            return Err(format!(
                "{owner} schedule: decay must lie in [0, 1], got {}",
                self.decay
            ));
        }
        if !(0.0..=1.0).contains(&self.narrowing_start) {
            return Err(format!(
                "{owner} schedule: narrowing_start must lie in [0, 1], got {}",
                self.narrowing_start
            ));
        }
        Ok(())
    }

    /// The first iteration from which the data decays and (with `narrowing`) is narrowed as such, of
    /// `training_iterations`: ⌊share·N⌋ (the epsilon keeps ⌊(2/3)·15⌋ at 10 despite 2/3's rounding).
    pub fn narrowing_start(&self, training_iterations: u32) -> u32 {
        (training_iterations as f64 * self.narrowing_start + 1e-9).floor() as u32
    }

    /// True if the data of `iteration` is trained with iterative narrowing.
    pub fn narrows(&self, iteration: u32, training_iterations: u32) -> bool {
        self.narrowing && iteration >= self.narrowing_start(training_iterations)
    }

    /// The factor on the statistics of the iterations before `iteration` when its data is added.
    pub fn decay_before(&self, iteration: u32, training_iterations: u32) -> f64 {
        if iteration >= self.narrowing_start(training_iterations) {
            NARROWING_DECAY
        } else {
            self.decay
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The octree's original rule, ⌊2N/3⌋ in integers, is the shared one at the default share.
    #[test]
    fn the_default_start_is_two_thirds_rounded_down() {
        let s = Schedule::default();
        for n in 0..2000 {
            assert_eq!(s.narrowing_start(n), 2 * n / 3, "N = {n}");
        }
    }

    #[test]
    fn decay_and_narrowing_switch_at_the_start() {
        let s = Schedule::default();
        assert_eq!(s.narrowing_start(15), 10);
        assert!(!s.narrows(9, 15) && s.narrows(10, 15));
        assert_eq!((s.decay_before(9, 15), s.decay_before(10, 15)), (0.5, 0.25));
        let off = Schedule {
            narrowing: false,
            ..s
        };
        assert!(!off.narrows(14, 15));
        assert_eq!(off.decay_before(10, 15), NARROWING_DECAY);
    }
}
