//! The mean radiance the shading points of a region reflect towards their paths, for MIS-compensated
//! training weights (Karlík et al. 2019, "MIS compensation").
//!
//! Sampled with probability α from the guide and 1 − α from the BSDF, a vertex's variance is least where
//! α·p_guide ∝ max(0, f/I − κ·p_bsdf): the guide should hold what the BSDF does not already sample well.
//! A segment sampled with p_mix at a vertex of throughput T carries c = T·f/p_mix, and the vertex's
//! expected contribution is T·L_o, L_o the radiance it reflects; so the compensated weight of the
//! segment is max(0, c − κ·T·L_o·p_bsdf/p_mix). Where the light arrives evenly (a room lit by its own
//! walls) c ≈ T·L_o·p_bsdf/p_mix and the segment is (1 − κ)·c; through a pinhole c is many times that
//! and hardly changes. L_o is the mean of c/T over every training vertex of a region, including those
//! whose continuation carried nothing.

use glam::DVec3;

/// Vertices a cell needs before its mean is used (otherwise the next coarser level's).
const MIN_CELL_VERTICES: f64 = 64.0;
/// Cells per axis of the finest level (levels 1, 2, 4, …, this).
const FINEST: usize = 16;

/// Per-region means of the reflected radiance c/T over a hierarchy of grids over a box.
#[derive(Clone, Debug, Default)]
pub struct ReflectedRadiance {
    lo: DVec3,
    extent: DVec3,
    /// Per level (resolution 1, 2, 4, …): Σ c/T and the number of vertices, per cell.
    levels: Vec<(usize, Vec<f64>, Vec<f64>)>,
}

impl ReflectedRadiance {
    /// An empty hierarchy over the box [`lo`, `hi`] (its two corners).
    pub fn new((lo, hi): (DVec3, DVec3)) -> Self {
        let mut levels = Vec::new();
        let mut res = 1;
        while res <= FINEST {
            levels.push((res, vec![0.0; res * res * res], vec![0.0; res * res * res]));
            res *= 2;
        }
        Self {
            lo,
            extent: (hi - lo).max(DVec3::splat(1e-12)),
            levels,
        }
    }

    fn cell(&self, x: DVec3, res: usize) -> usize {
        let u = ((x - self.lo) / self.extent).clamp(DVec3::ZERO, DVec3::splat(1.0 - 1e-9));
        let i = (u * res as f64).as_uvec3();
        (i.z as usize * res + i.y as usize) * res + i.x as usize
    }

    /// Counts one vertex at `x` that reflected `radiance` (c/T; 0 if its continuation carried nothing).
    pub fn add(&mut self, x: DVec3, radiance: f64) {
        if !(x.is_finite() && radiance >= 0.0 && radiance.is_finite()) {
            return;
        }
        for l in 0..self.levels.len() {
            let res = self.levels[l].0;
            let c = self.cell(x, res);
            let (_, sum, count) = &mut self.levels[l];
            sum[c] += radiance;
            count[c] += 1.0;
        }
    }

    /// Multiplies every sum and count by `f` (older iterations fade as the guide's statistics do).
    pub fn decay(&mut self, f: f64) {
        for (_, sum, count) in &mut self.levels {
            sum.iter_mut().for_each(|v| *v *= f);
            count.iter_mut().for_each(|v| *v *= f);
        }
    }

    /// The mean reflected radiance at `x`: the finest cell with enough vertices, else 0.
    pub fn at(&self, x: DVec3) -> f64 {
        for (res, sum, count) in self.levels.iter().rev() {
            let c = self.cell(x, *res);
            if count[c] >= MIN_CELL_VERTICES {
                return sum[c] / count[c];
            }
        }
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> ReflectedRadiance {
        ReflectedRadiance::new((DVec3::splat(-1.0), DVec3::splat(1.0)))
    }

    #[test]
    fn a_cell_with_enough_vertices_gives_their_mean_zeros_included() {
        let mut g = grid();
        // 100 vertices in the corner cell of the finest level (side 2/16): a quarter reflected 4.
        for i in 0..100 {
            let x = DVec3::splat(-0.95 + 0.0005 * i as f64);
            g.add(x, if i % 4 == 0 { 4.0 } else { 0.0 });
        }
        assert!((g.at(DVec3::splat(-0.94)) - 1.0).abs() < 1e-12);
        // Decay fades sums and counts alike: the mean stays while the faded count is enough...
        g.decay(0.8);
        assert!((g.at(DVec3::splat(-0.94)) - 1.0).abs() < 1e-12);
        // ...and below the minimum (80 → 40 < 64, at every level) the region is unknown again.
        g.decay(0.5);
        assert_eq!(g.at(DVec3::splat(-0.94)), 0.0);
    }

    #[test]
    fn sparse_cells_use_the_coarser_level_and_an_empty_grid_gives_zero() {
        let mut g = grid();
        assert_eq!(g.at(DVec3::ZERO), 0.0);
        // 64 vertices spread over one octant: each finest cell holds few, the octant's cell enough.
        let mut k = 0;
        for i in 0..4 {
            for j in 0..4 {
                for l in 0..4 {
                    let x = DVec3::new(
                        0.1 + 0.2 * i as f64,
                        0.1 + 0.2 * j as f64,
                        0.1 + 0.2 * l as f64,
                    );
                    g.add(x, k as f64);
                    k += 1;
                }
            }
        }
        assert!((g.at(DVec3::splat(0.5)) - 31.5).abs() < 1e-9);
        // The other octants fall back to the whole box, whose 64 vertices are the same.
        assert!((g.at(DVec3::splat(-0.5)) - 31.5).abs() < 1e-9);
        // Invalid vertices are ignored.
        g.add(DVec3::splat(f64::NAN), 1.0);
        g.add(DVec3::ZERO, -1.0);
        g.add(DVec3::ZERO, f64::INFINITY);
        assert!((g.at(DVec3::splat(-0.5)) - 31.5).abs() < 1e-9);
    }
}
