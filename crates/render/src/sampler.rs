//! Per-sample random number streams. Every stream is a pure function of (seed, pixel, sample index), which
//! is what makes renders bit-identical for a fixed seed whatever the number of threads.

use glam::Vec2;

/// Which sample generator a render uses (Mitsuba's `<sampler>` plugin).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SamplerKind {
    /// Independent uniform random numbers (PCG32), Mitsuba's `independent`.
    Independent,
    /// Owen-scrambled Sobol' points (Burley 2020), used for `stratified`, `multijitter`, `ldsampler`,
    /// `sobol` and `orthogonal`; dimensions past the table's end fall back to PCG32.
    Sobol,
}

/// A 64-bit mix (SplitMix64 finaliser), used to derive decorrelated seeds.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E3779B97F4A7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
    z ^ (z >> 31)
}

/// PCG32 (O'Neill 2014, XSH RR): small, fast, statistically good.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator for stream `stream` from seed `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// Next 32 uniformly distributed bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform float in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform double in [0, 1).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }
}

/// The random stream of one pixel sample.
#[derive(Clone, Debug)]
pub struct Sampler {
    kind: SamplerKind,
    rng: Pcg32,
    sample_index: u32,
    scramble: u32,
    dim: u32,
}

/// Number of Sobol' dimensions before falling back to PCG32.
const SOBOL_DIMS: u32 = sobol_burley::NUM_DIMENSIONS;

impl Sampler {
    /// The stream for sample `sample_index` of pixel `pixel` (a linear pixel index) under `seed`.
    pub fn new(kind: SamplerKind, seed: u64, pixel: u64, sample_index: u32) -> Self {
        let pixel_key = mix64(seed ^ mix64(pixel.wrapping_add(0x51_7CC1_B727_220A)));
        let rng = match kind {
            SamplerKind::Independent => {
                Pcg32::new(mix64(pixel_key ^ sample_index as u64), pixel_key)
            }
            SamplerKind::Sobol => Pcg32::new(
                mix64(pixel_key.wrapping_add(sample_index as u64)),
                0x2545F491,
            ),
        };
        Sampler {
            kind,
            rng,
            sample_index,
            scramble: (pixel_key >> 32) as u32,
            dim: 0,
        }
    }

    /// A free-running independent stream (for training-data subsampling, tests and other non-pixel uses).
    pub fn independent(seed: u64, stream: u64) -> Self {
        Sampler {
            kind: SamplerKind::Independent,
            rng: Pcg32::new(mix64(seed), stream),
            sample_index: 0,
            scramble: 0,
            dim: 0,
        }
    }

    /// Next 1D sample in [0, 1).
    #[inline(always)]
    pub fn next_1d(&mut self) -> f32 {
        match self.kind {
            SamplerKind::Independent => self.rng.next_f32(),
            SamplerKind::Sobol => {
                if self.dim < SOBOL_DIMS {
                    let v = sobol_burley::sample(self.sample_index, self.dim, self.scramble);
                    self.dim += 1;
                    v.min(1.0 - f32::EPSILON / 2.0)
                } else {
                    self.rng.next_f32()
                }
            }
        }
    }

    /// Next 2D sample in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        let y = self.next_1d();
        Vec2::new(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_seed_pixel_and_index() {
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let a: Vec<f32> = {
                let mut s = Sampler::new(kind, 7, 123, 5);
                (0..40).map(|_| s.next_1d()).collect()
            };
            let b: Vec<f32> = {
                let mut s = Sampler::new(kind, 7, 123, 5);
                (0..40).map(|_| s.next_1d()).collect()
            };
            assert_eq!(a, b);
            for (seed, pixel, index) in [(8, 123, 5), (7, 124, 5), (7, 123, 6)] {
                let mut s = Sampler::new(kind, seed, pixel, index);
                let c: Vec<f32> = (0..40).map(|_| s.next_1d()).collect();
                assert_ne!(
                    a, c,
                    "{kind:?}: ({seed}, {pixel}, {index}) repeats another stream"
                );
            }
            assert!(a.iter().all(|v| (0.0..1.0).contains(v)));
        }
    }

    #[test]
    fn sobol_first_dimensions_are_stratified_per_pixel() {
        // The first 256 Owen-scrambled Sobol' points in dimensions (0, 1) form a (0, 8, 2)-net: exactly one
        // point in each of the 16 × 16 strata.
        for pixel in [0u64, 17, 99_999] {
            let mut counts = [0u32; 256];
            for i in 0..256 {
                let mut s = Sampler::new(SamplerKind::Sobol, 3, pixel, i);
                let p = s.next_2d();
                counts[(p.y * 16.0) as usize * 16 + (p.x * 16.0) as usize] += 1;
            }
            assert!(counts.iter().all(|&c| c == 1), "pixel {pixel}: {counts:?}");
        }
    }

    #[test]
    fn independent_values_are_uniform() {
        let mut s = Sampler::independent(1, 2);
        let n = 200_000;
        let mut bins = [0u32; 10];
        let mut sum = 0.0f64;
        for _ in 0..n {
            let v = s.next_1d();
            bins[(v * 10.0) as usize] += 1;
            sum += v as f64;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.003);
        // Chi-square with 9 degrees of freedom: 27.9 is the 0.999 quantile.
        let e = n as f64 / 10.0;
        let chi2: f64 = bins.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 27.9, "chi2 {chi2}");
    }
}
