//! The box a guide covers.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// An axis-aligned box (the scene bounds a distribution may cover).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb3 {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb3 {
    /// The box made usable as a guide's domain: an error naming `owner` if it is not finite or empty; an
    /// axis of zero extent (a flat scene) padded to 1e-3 of the largest extent (or 1 if all are zero) so
    /// that every cell and every normalisation has a positive volume.
    pub fn padded(self, owner: &str) -> Result<Aabb3, String> {
        if !self.min.is_finite() || !self.max.is_finite() || self.min.cmpgt(self.max).any() {
            return Err(format!(
                "{owner} needs a finite non-empty box, got {:?}..{:?}",
                self.min, self.max
            ));
        }
        let extent = self.max - self.min;
        let largest = extent.max_element();
        let pad = if largest > 0.0 { largest * 1e-3 } else { 1.0 };
        let mut out = self;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                out.min[axis] -= pad / 2.0;
                out.max[axis] += pad / 2.0;
            }
        }
        Ok(out)
    }
}
