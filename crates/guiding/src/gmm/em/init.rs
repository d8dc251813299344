//! Weighted k-means++ initialisation of a mixture's first fit.

use glam::DVec3;

use super::stats::{raw_to_stats, SuffStats};
use crate::gmm::cumulative::pick_interval;
use crate::gmm::rays::{mix64, WeightedPoint};

/// Points k-means++ seeds on (a deterministic stride subset of the first update's points).
const INIT_SAMPLE: usize = 65_536;
/// Weighted Lloyd iterations after seeding.
const LLOYD_ITERATIONS: usize = 3;

/// A small deterministic generator for the initialisation (SplitMix64).
struct SplitMix(u64);

impl SplitMix {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        (mix64(self.0) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Weighted k-means++ seeding and Lloyd iterations on a stride subset of `points`; returns the
/// clusters' statistics (empty clusters dropped).
pub fn kmeans_init(points: &[WeightedPoint], k: usize, seed: u64) -> Vec<SuffStats> {
    let stride = points.len().div_ceil(INIT_SAMPLE).max(1);
    let sample: Vec<(DVec3, f64)> = points
        .iter()
        .step_by(stride)
        .map(|p| (p.pos(), p.weight as f64))
        .filter(|(_, w)| *w > 0.0)
        .collect();
    let k = k.min(sample.len());
    if k == 0 {
        return Vec::new();
    }
    let mut rng = SplitMix(seed);
    let total: f64 = sample.iter().map(|(_, w)| w).sum();
    let Some((first, _, _)) = pick_interval(sample.iter().map(|(_, w)| *w), rng.unit() * total)
    else {
        return Vec::new();
    };
    let mut centers = vec![sample[first].0];
    let mut d2: Vec<f64> = sample
        .iter()
        .map(|(y, _)| y.distance_squared(centers[0]))
        .collect();
    while centers.len() < k {
        let total: f64 = sample.iter().zip(&d2).map(|((_, w), d)| w * d).sum();
        if !(total > 0.0) {
            break;
        }
        let weights = sample.iter().zip(&d2).map(|((_, w), d)| w * d);
        let Some((next, _, _)) = pick_interval(weights, rng.unit() * total) else {
            break;
        };
        let c = sample[next].0;
        for (d, (y, _)) in d2.iter_mut().zip(&sample) {
            *d = d.min(y.distance_squared(c));
        }
        centers.push(c);
    }
    let nearest = |y: DVec3, centers: &[DVec3]| {
        let mut best = (f64::INFINITY, 0);
        for (j, c) in centers.iter().enumerate() {
            let d = y.distance_squared(*c);
            if d < best.0 {
                best = (d, j);
            }
        }
        best.1
    };
    for _ in 0..LLOYD_ITERATIONS {
        let mut sums = vec![(DVec3::ZERO, 0.0f64); centers.len()];
        for (y, w) in &sample {
            let j = nearest(*y, &centers);
            sums[j].0 += (*y - centers[j]) * *w;
            sums[j].1 += w;
        }
        for (c, (s, w)) in centers.iter_mut().zip(&sums) {
            if *w > 0.0 {
                *c += *s / *w;
            }
        }
    }
    let mut acc = vec![[0.0f64; 10]; centers.len()];
    for (y, w) in &sample {
        let j = nearest(*y, &centers);
        let d = *y - centers[j];
        let a = &mut acc[j];
        a[0] += w;
        a[1] += w * d.x;
        a[2] += w * d.y;
        a[3] += w * d.z;
        a[4] += w * d.x * d.x;
        a[5] += w * d.x * d.y;
        a[6] += w * d.x * d.z;
        a[7] += w * d.y * d.y;
        a[8] += w * d.y * d.z;
        a[9] += w * d.z * d.z;
    }
    acc.iter()
        .zip(&centers)
        .map(|(a, c)| raw_to_stats(a, *c))
        .filter(|s| s.weight > 0.0)
        .collect()
}
