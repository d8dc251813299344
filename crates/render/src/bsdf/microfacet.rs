//! Beckmann and GGX microfacet distributions with Smith shadowing-masking and visible-normal sampling,
//! as in Mitsuba 3 (`microfacet.h`): Walter et al. 2007 for the distributions, Heitz 2018 ("Sampling
//! the GGX distribution of visible normals") for GGX and Jakob 2014 ("An improved visible normal
//! sampling routine for the Beckmann distribution", a numerically inverted Heitz & d'Eon 2014) for
//! Beckmann.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The microfacet normal distribution family (`distribution` parameter).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetKind {
    /// Beckmann (Gaussian random surface).
    Beckmann,
    /// GGX / Trowbridge-Reitz (long-tailed).
    Ggx,
}

/// An (optionally anisotropic) microfacet distribution.
#[derive(Clone, Copy, Debug)]
pub struct Microfacet {
    /// Family.
    pub kind: MicrofacetKind,
    /// Roughness along the local x (tangent) axis.
    pub alpha_u: f32,
    /// Roughness along the local y (bitangent) axis.
    pub alpha_v: f32,
    /// Sample the distribution of visible normals (true) or the full NDF D(m)·cos θm (false).
    pub sample_visible: bool,
}

const INV_SQRT_PI: f32 = 0.564_189_6;

impl Microfacet {
    /// A distribution; roughness is clamped to 1e-4 as in Mitsuba.
    pub fn new(kind: MicrofacetKind, alpha_u: f32, alpha_v: f32, sample_visible: bool) -> Self {
        Microfacet {
            kind,
            alpha_u: alpha_u.max(1e-4),
            alpha_v: alpha_v.max(1e-4),
            sample_visible,
        }
    }

    /// The same distribution with both roughnesses scaled by `s`.
    pub fn scaled(&self, s: f32) -> Self {
        Microfacet {
            alpha_u: self.alpha_u * s,
            alpha_v: self.alpha_v * s,
            ..*self
        }
    }

    /// The smaller of the two roughnesses.
    pub fn min_alpha(&self) -> f32 {
        self.alpha_u.min(self.alpha_v)
    }

    /// D(m), the microfacet normal density per unit projected area.
    #[inline]
    pub fn eval(&self, m: Vec3) -> f32 {
        let cos2 = m.z * m.z;
        if m.z <= 0.0 {
            return 0.0;
        }
        let au = self.alpha_u;
        let av = self.alpha_v;
        let xu = m.x / au;
        let yv = m.y / av;
        let result = match self.kind {
            MicrofacetKind::Beckmann => {
                (-(xu * xu + yv * yv) / cos2).exp() / (PI * au * av * cos2 * cos2)
            }
            MicrofacetKind::Ggx => {
                let t = xu * xu + yv * yv + cos2;
                1.0 / (PI * au * av * t * t)
            }
        };
        if result * m.z > 1e-20 && result.is_finite() {
            result
        } else {
            0.0
        }
    }

    /// Smith's G1 for direction `v` and microfacet normal `m`; 0 when `v` sees the back of the microfacet.
    #[inline]
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy_alpha_2 = (self.alpha_u * v.x).powi(2) + (self.alpha_v * v.y).powi(2);
        if xy_alpha_2 == 0.0 {
            return 1.0;
        }
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        match self.kind {
            MicrofacetKind::Beckmann => {
                // Exact Smith Λ of the Beckmann distribution (Mitsuba uses Walter's rational fit, off by
                // up to 0.35 %, which would make the visible-normal pdf integrate to slightly less than 1
                // at grazing angles).
                let a = 1.0 / tan_theta_alpha_2.sqrt();
                if a >= 6.0 {
                    1.0
                } else {
                    let lambda = 0.5 * (erf(a) - 1.0) + INV_SQRT_PI * 0.5 * (-a * a).exp() / a;
                    1.0 / (1.0 + lambda)
                }
            }
            MicrofacetKind::Ggx => 2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt()),
        }
    }

    /// Separable shadowing-masking G = G1(wi)·G1(wo).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Density of [`Microfacet::sample`] for normal `m` given `wi` (which must have wi.z > 0).
    #[inline]
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        let d = self.eval(m);
        if self.sample_visible {
            if wi.z <= 0.0 {
                return 0.0;
            }
            d * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z
        } else {
            d * m.z
        }
    }

    /// Samples a microfacet normal visible from `wi` (wi.z > 0), or from the full NDF; returns the
    /// normal and its density.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> (Vec3, f32) {
        if !self.sample_visible {
            return self.sample_ndf(u);
        }
        // Stretch wi to the configuration with unit roughness.
        let wi_p = Vec3::new(self.alpha_u * wi.x, self.alpha_v * wi.y, wi.z).normalize();
        let sin_theta = (1.0 - wi_p.z * wi_p.z).max(0.0).sqrt();
        let (sin_phi, cos_phi) = if sin_theta > 1e-7 {
            (
                (wi_p.y / sin_theta).clamp(-1.0, 1.0),
                (wi_p.x / sin_theta).clamp(-1.0, 1.0),
            )
        } else {
            (0.0, 1.0)
        };
        let slope = self.sample_visible_11(wi_p.z, u);
        // Rotate and unstretch.
        let sx = (cos_phi * slope.x - sin_phi * slope.y) * self.alpha_u;
        let sy = (sin_phi * slope.x + cos_phi * slope.y) * self.alpha_v;
        let m = Vec3::new(-sx, -sy, 1.0).normalize();
        (m, self.pdf(wi, m))
    }

    /// Slopes of a visible normal for unit roughness and incidence cos θ = `cos_theta_i`.
    fn sample_visible_11(&self, cos_theta_i: f32, u: Vec2) -> Vec2 {
        match self.kind {
            MicrofacetKind::Beckmann => {
                let tan_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
                let cot_theta_i = 1.0 / tan_theta_i;
                // Search in the erf() domain; start from the analytic solution for θi = π/2.
                let maxval = erf(cot_theta_i);
                let u = u.clamp(Vec2::splat(1e-6), Vec2::splat(1.0 - 1e-6));
                let mut x = maxval - (maxval + 1.0) * erf((-u.x.ln()).sqrt());
                let target = u.x
                    * (1.0
                        + maxval
                        + INV_SQRT_PI * tan_theta_i * (-cot_theta_i * cot_theta_i).exp());
                for _ in 0..3 {
                    let slope = erfinv(x);
                    let value =
                        1.0 + x + INV_SQRT_PI * tan_theta_i * (-slope * slope).exp() - target;
                    let derivative = 1.0 - slope * tan_theta_i;
                    x -= value / derivative;
                }
                Vec2::new(erfinv(x), erfinv(2.0 * u.y - 1.0))
            }
            MicrofacetKind::Ggx => {
                // Heitz 2018: sample a disk, squash the half facing away, project to the hemisphere.
                let mut p = crate::warp::square_to_uniform_disk_concentric(u);
                let s = 0.5 * (1.0 + cos_theta_i);
                let h = (1.0 - p.x * p.x).max(0.0).sqrt();
                p.y = h + s * (p.y - h);
                let z = (1.0 - p.length_squared()).max(0.0).sqrt();
                let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
                let norm = 1.0 / (sin_theta_i * p.y + cos_theta_i * z);
                Vec2::new(cos_theta_i * p.y - sin_theta_i * z, p.x) * norm
            }
        }
    }

    /// Samples D(m)·cos θm (Walter et al. 2007).
    fn sample_ndf(&self, u: Vec2) -> (Vec3, f32) {
        let (sin_phi, cos_phi, alpha_2) = if self.alpha_u == self.alpha_v {
            let (s, c) = (2.0 * PI * u.y).sin_cos();
            (s, c, self.alpha_u * self.alpha_u)
        } else {
            let ratio = self.alpha_v / self.alpha_u;
            let tmp = ratio * (2.0 * PI * u.y).tan();
            let cos_phi = (1.0 / (tmp * tmp + 1.0).sqrt()).copysign((u.y - 0.5).abs() - 0.25);
            let sin_phi = cos_phi * tmp;
            let a2 = 1.0 / ((cos_phi / self.alpha_u).powi(2) + (sin_phi / self.alpha_v).powi(2));
            (sin_phi, cos_phi, a2)
        };
        let cos_theta = match self.kind {
            MicrofacetKind::Beckmann => 1.0 / (1.0 - alpha_2 * (1.0 - u.x).ln()).sqrt(),
            MicrofacetKind::Ggx => {
                let tan2 = alpha_2 * u.x / (1.0 - u.x).max(1e-12);
                1.0 / (1.0 + tan2).sqrt()
            }
        };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let m = Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta);
        (m, self.eval(m) * m.z)
    }
}

/// The error function (Numerical Recipes' Chebyshev fit of erfc, relative error < 1.2e-7), in single
/// precision: Beckmann sampling calls it and [`erfinv`] a dozen times per sample, and the f64
/// exponentials were a tenth of a textured interior's render time.
#[inline]
pub fn erf(x: f32) -> f32 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_2
        + t * (1.000_023_7
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_204
                                + t * (1.488_515_9 + t * (-0.822_152_2 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 {
        1.0 - erfc
    } else {
        erfc - 1.0
    }
}

/// The inverse error function: Giles' (2010) single-precision fit, as Dr.Jit's `erfinv` (relative
/// error about 1e-7 where it matters; at most 4.1e-7 in erf(erfinv(x)) − x). Beckmann's visible-normal
/// sampling calls it five times per sample; refining it by Newton steps in f64 made it a quarter of a
/// textured interior's render time.
#[inline]
pub fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-1.0 + 1e-7, 1.0 - 1e-7);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8f32;
        for c in [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            0.246_640_73,
            1.501_409_4,
        ] {
            p = c + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -2.002_142_6e-4f32;
        for c in [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ] {
            p = c + p * w;
        }
        p
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_and_inverse() {
        assert!((erf(0.5) - 0.520_499_9).abs() < 1e-6);
        assert!((erf(-1.5) + 0.966_105_1).abs() < 1e-6);
        for x in [-0.999f32, -0.7, -0.1, 0.0, 0.3, 0.9, 0.99] {
            assert!((erf(erfinv(x)) - x).abs() < 1e-5, "{x}");
        }
        // The single-precision inverse over the whole domain: the round trip is as close as f32 allows.
        let worst = (-99_999..100_000)
            .map(|i| i as f32 / 100_000.0)
            .map(|x| (erf(erfinv(x)) - x).abs())
            .fold(0.0f32, f32::max);
        eprintln!("largest |erf(erfinv(x)) - x|: {worst:e}");
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn ndf_is_normalised() {
        // ∫ D(m) cos θm dω = 1.
        for kind in [MicrofacetKind::Beckmann, MicrofacetKind::Ggx] {
            for (au, av) in [(0.1f32, 0.1f32), (0.3, 0.6), (0.8, 0.8)] {
                let d = Microfacet::new(kind, au, av, true);
                let i = focal_testkit::sphere_integral(|m| (d.eval(m) * m.z.max(0.0)) as f64);
                assert!((i - 1.0).abs() < 2e-3, "{kind:?} {au} {av}: {i}");
            }
        }
    }
}
