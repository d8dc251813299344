//! Helpers shared by the GMM guide tests.
#![allow(dead_code)]

pub mod training;

use std::f64::consts::PI;

use focal_guiding::gmm::{Gaussian3, Mixture, Sym3};
use focal_guiding::{Aabb3, TrainingSegment, UpdateContext};
use glam::{DVec3, Vec3};

/// A small deterministic generator (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }
    /// Box–Muller (independent of the library's inverse-CDF normals).
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.f64();
        let u2 = self.f64();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
    pub fn sphere(&mut self) -> DVec3 {
        let z = 1.0 - 2.0 * self.f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * self.f64();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
    pub fn in_box(&mut self, lo: DVec3, hi: DVec3) -> DVec3 {
        lo + (hi - lo) * DVec3::new(self.f64(), self.f64(), self.f64())
    }
}

/// A random rotation applied to a random diagonal covariance with standard deviations in
/// [`min_sigma`, `max_sigma`], centred at `center` plus a random offset.
pub fn random_gaussian(rng: &mut Rng, center: DVec3, min_sigma: f64, max_sigma: f64) -> Gaussian3 {
    let sig = DVec3::new(
        min_sigma + (max_sigma - min_sigma) * rng.f64(),
        min_sigma + (max_sigma - min_sigma) * rng.f64(),
        min_sigma + (max_sigma - min_sigma) * rng.f64(),
    );
    let a = rng.sphere();
    let b = (rng.sphere() - a * a.dot(rng.sphere())).normalize_or_zero();
    let b = if b == DVec3::ZERO {
        a.any_orthonormal_vector()
    } else {
        (b - a * a.dot(b)).normalize()
    };
    let c = a.cross(b);
    let mut cov = Sym3::ZERO;
    for (axis, s) in [(a, sig.x), (b, sig.y), (c, sig.z)] {
        cov = cov + Sym3::outer(axis) * (s * s);
    }
    let mean = center + DVec3::new(rng.normal(), rng.normal(), rng.normal()) * 0.2;
    Gaussian3::new(mean, cov).unwrap()
}

/// A random mixture of `k` components around `center`.
pub fn random_mixture(
    rng: &mut Rng,
    k: usize,
    center: DVec3,
    min_sigma: f64,
    max_sigma: f64,
) -> Mixture {
    let comps: Vec<Gaussian3> = (0..k)
        .map(|_| random_gaussian(rng, center, min_sigma, max_sigma))
        .collect();
    let weights: Vec<f64> = (0..k).map(|_| 0.2 + rng.f64()).collect();
    Mixture::new(&weights, comps).unwrap()
}

/// ∫_a^b f by adaptive Simpson to a relative accuracy `rel` of the total, starting from `panels`
/// panels (so narrow peaks are found).
pub fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, rel: f64, panels: usize) -> f64 {
    #[allow(clippy::too_many_arguments)]
    fn rec(
        f: &dyn Fn(f64) -> f64,
        a: f64,
        b: f64,
        fa: f64,
        fm: f64,
        fb: f64,
        s: f64,
        eps: f64,
        depth: u32,
    ) -> f64 {
        let m = 0.5 * (a + b);
        let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
        let (flm, frm) = (f(lm), f(rm));
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        let delta = left + right - s;
        if depth == 0 || delta.abs() <= 15.0 * eps {
            return left + right + delta / 15.0;
        }
        rec(f, a, m, fa, flm, fm, left, eps / 2.0, depth - 1)
            + rec(f, m, b, fm, frm, fb, right, eps / 2.0, depth - 1)
    }
    let h = (b - a) / panels as f64;
    let mut panel = Vec::with_capacity(panels);
    let mut coarse = 0.0;
    for i in 0..panels {
        let x0 = a + h * i as f64;
        let x1 = if i + 1 == panels { b } else { x0 + h };
        let (fa, fm, fb) = (f(x0), f(0.5 * (x0 + x1)), f(x1));
        let s = (x1 - x0) / 6.0 * (fa + 4.0 * fm + fb);
        coarse += s.abs();
        panel.push((x0, x1, fa, fm, fb, s));
    }
    let eps = rel * coarse / panels as f64;
    panel
        .iter()
        .map(|&(x0, x1, fa, fm, fb, s)| rec(f, x0, x1, fa, fm, fb, s, eps, 40))
        .sum()
}

/// The scene box of the training tests (anisotropic, off-origin).
pub fn scene_box() -> Aabb3 {
    Aabb3 {
        min: Vec3::new(-1.0, 0.0, -0.5),
        max: Vec3::new(1.5, 1.0, 1.0),
    }
}

pub fn context(iteration: u32, training_iterations: u32) -> UpdateContext {
    UpdateContext {
        iteration,
        training_iterations,
        final_build: iteration + 1 == training_iterations,
        threads: 0,
    }
}

/// Distance from `o` (inside the box) to the box boundary along unit `d`.
pub fn exit_distance(aabb: Aabb3, o: DVec3, d: DVec3) -> f64 {
    let mut t = f64::INFINITY;
    for a in 0..3 {
        if d[a] > 0.0 {
            t = t.min((aabb.max[a] as f64 - o[a]) / d[a]);
        } else if d[a] < 0.0 {
            t = t.min((aabb.min[a] as f64 - o[a]) / d[a]);
        }
    }
    t
}

/// A segment through `y` in a uniformly random direction, from and to random points inside the box on
/// that line (non-glossy endpoint, uniform pdf, weight `w`).
pub fn segment_through(rng: &mut Rng, aabb: Aabb3, y: DVec3, w: f32) -> TrainingSegment {
    let d = rng.sphere();
    let back = rng.f64() * exit_distance(aabb, y, -d);
    let forward = rng.f64() * exit_distance(aabb, y, d);
    TrainingSegment {
        origin: (y - d * back).as_vec3(),
        direction: d.as_vec3(),
        distance: (back + forward) as f32,
        weight: w,
        pdf: (1.0 / (4.0 * PI)) as f32,
        bsdf_pdf: (1.0 / (4.0 * PI)) as f32,
        guide_pdf: 0.0,
        guide_fraction: 0.0,
        glossy_endpoint: false,
        glossy_origin: false,
        refracting_endpoint: false,
        emitted: 0.0,
        emitter_pdf: 0.0,
        pixel_weight: 1.0,
    }
}
