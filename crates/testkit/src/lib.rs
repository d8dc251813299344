//! Statistical test helpers shared by the focal crates' tests.
//!
//! The main tool is [`chi2_sphere_test`], a goodness-of-fit test between a sampling routine for
//! directions on the unit sphere and the density it claims to sample (as Mitsuba's `ChiSquareTest`).
//! It is generic: it knows nothing about BSDFs, only directions (`glam::Vec3`) and densities per unit
//! solid angle, so the guiding library can reuse it for its own distributions.
//!
//! How the test works:
//! 1. The sphere is cut into a grid of bins, uniform in θ ∈ [0, π] (polar angle from +Z) and in
//!    φ ∈ [0, 2π). Uniform-in-θ bins resolve peaks near the poles better than uniform-in-cos θ bins.
//! 2. `N` samples are drawn with uniform random numbers from a fixed-seed generator. A sample that
//!    returns `None`, or has weight 0, is *drawn but not binned* (a rejected sample, or a delta lobe
//!    whose density is not part of `pdf`): it belongs to an extra "not binned" category.
//! 3. The expected count of each bin is `N · ∫_bin pdf dω`, computed by nested adaptive Simpson
//!    quadrature in (cos θ, φ); the "not binned" category expects `N · (1 − ∫_S² pdf dω)`.
//! 4. Categories with expected count below `min_expected` are pooled into one (Cochran's rule); a
//!    pooled cell that still expects nothing but received samples fails the test outright.
//! 5. Pearson's statistic is compared with the χ² distribution (statrs) with `cells − 1` degrees of
//!    freedom. The test rejects when the p-value is below the Šidák-corrected level
//!    `1 − (1 − significance)^(1/num_tests)`, so a test suite of `num_tests` such tests has an overall
//!    false-rejection probability of `significance`.
//! 6. Independently, the total mass is checked: `∫ pdf dω` must match the fraction of samples that were
//!    binned within `integral_tolerance` plus five binomial standard deviations.

use glam::{Vec2, Vec3};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::PI;
use std::fmt;

/// Parameters of [`chi2_sphere_test`].
#[derive(Clone, Debug)]
pub struct Chi2Options {
    /// Number of bins in θ (polar angle, uniform in angle). Even values put a bin edge on the equator,
    /// where hemispherical densities are discontinuous.
    pub theta_bins: usize,
    /// Number of bins in φ.
    pub phi_bins: usize,
    /// Number of samples drawn.
    pub samples: usize,
    /// Cells expecting fewer samples than this are pooled.
    pub min_expected: f64,
    /// Overall significance level of the whole family of tests.
    pub significance: f64,
    /// Number of tests in the family (for the Šidák correction).
    pub num_tests: usize,
    /// Allowed absolute difference between ∫ pdf and the binned fraction (on top of 5 binomial σ),
    /// to absorb quadrature error.
    pub integral_tolerance: f64,
    /// Relative accuracy goal of the per-bin quadrature.
    pub quadrature_tolerance: f64,
    /// Seed of the random numbers fed to the sampler.
    pub seed: u64,
}

impl Default for Chi2Options {
    fn default() -> Self {
        Chi2Options {
            theta_bins: 20,
            phi_bins: 40,
            samples: 200_000,
            min_expected: 5.0,
            significance: 0.01,
            num_tests: 1,
            integral_tolerance: 2e-3,
            quadrature_tolerance: 1e-5,
            seed: 0x5eed_f0ca1,
        }
    }
}

/// Outcome of [`chi2_sphere_test`].
#[derive(Clone, Debug)]
pub struct Chi2Result {
    /// True if neither the χ² test nor the mass check rejected.
    pub passed: bool,
    /// p-value of Pearson's statistic (1 when there was nothing to compare).
    pub p_value: f64,
    /// The per-test rejection threshold after the Šidák correction.
    pub threshold: f64,
    /// Pearson's statistic.
    pub statistic: f64,
    /// Degrees of freedom used.
    pub dof: usize,
    /// ∫_S² pdf dω by quadrature.
    pub pdf_integral: f64,
    /// Fraction of the samples that were binned (returned a direction with weight 1).
    pub binned_fraction: f64,
    /// Why the test failed (empty if it passed).
    pub message: String,
}

impl fmt::Display for Chi2Result {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (p = {:.3e}, threshold {:.3e}, χ² = {:.1}, dof = {}, ∫pdf = {:.5}, binned = {:.5}){}{}",
            if self.passed { "passed" } else { "FAILED" },
            self.p_value,
            self.threshold,
            self.statistic,
            self.dof,
            self.pdf_integral,
            self.binned_fraction,
            if self.message.is_empty() { "" } else { ": " },
            self.message
        )
    }
}

/// A small deterministic PCG32 generator, so that tests do not depend on a random-number crate.
#[derive(Clone, Debug)]
pub struct TestRng {
    state: u64,
    inc: u64,
}

impl TestRng {
    /// A generator for the given seed.
    pub fn new(seed: u64) -> Self {
        let mut r = TestRng {
            state: 0,
            inc: (seed << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed ^ 0x853c_49e6_748f_ea9b);
        r.next_u32();
        r
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in [0, 1) with 53 random bits (two draws).
    pub fn next_f64(&mut self) -> f64 {
        let bits = ((self.next_u32() as u64) << 21) ^ (self.next_u32() as u64 >> 11);
        bits as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A standard normal variate (Box–Muller, two [`TestRng::next_f64`] draws).
    pub fn next_normal(&mut self) -> f64 {
        let (u1, u2) = (1.0 - self.next_f64(), self.next_f64());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Direction with cos θ = `z` and azimuth `phi`.
fn direction(z: f64, phi: f64) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

/// Adaptive Simpson on [a, b] with initial panel values `fa`, `fm`, `fb` and whole-panel estimate `s`.
#[allow(clippy::too_many_arguments)]
fn adaptive_simpson(
    f: &mut impl FnMut(f64) -> f64,
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
    let lm = 0.5 * (a + m);
    let rm = 0.5 * (m + b);
    let flm = f(lm);
    let frm = f(rm);
    let h = (b - a) / 12.0;
    let left = h * (fa + 4.0 * flm + fm);
    let right = h * (fm + 4.0 * frm + fb);
    let delta = left + right - s;
    if depth == 0 || delta.abs() <= 15.0 * eps {
        return left + right + delta / 15.0;
    }
    adaptive_simpson(f, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1)
        + adaptive_simpson(f, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1)
}

/// ∫_a^b f with `panels` initial panels (so that narrow peaks are not missed) refined adaptively.
fn integrate_1d(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, panels: usize, eps: f64) -> f64 {
    let h = (b - a) / panels as f64;
    let mut total = 0.0;
    let mut fa = f(a);
    for i in 0..panels {
        let x0 = a + h * i as f64;
        let x1 = if i + 1 == panels { b } else { x0 + h };
        let fm = f(0.5 * (x0 + x1));
        let fb = f(x1);
        let s = (x1 - x0) / 6.0 * (fa + 4.0 * fm + fb);
        total += adaptive_simpson(&mut f, x0, x1, fa, fm, fb, s, eps / panels as f64, 10);
        fa = fb;
    }
    total
}

/// ∫ pdf dω over the part of the sphere with cos θ ∈ [z0, z1] and φ ∈ [phi0, phi1].
fn integrate_patch(
    pdf: &impl Fn(Vec3) -> f64,
    z0: f64,
    z1: f64,
    phi0: f64,
    phi1: f64,
    eps: f64,
) -> f64 {
    integrate_1d(
        |phi| {
            integrate_1d(
                |z| pdf(direction(z, phi)).max(0.0),
                z0,
                z1,
                4,
                eps / (phi1 - phi0),
            )
        },
        phi0,
        phi1,
        4,
        eps,
    )
}

/// Expected probability mass of every (θ, φ) bin, θ-major.
fn bin_masses(
    pdf: &impl Fn(Vec3) -> f64,
    theta_bins: usize,
    phi_bins: usize,
    tol: f64,
) -> Vec<f64> {
    let mut masses = Vec::with_capacity(theta_bins * phi_bins);
    // Absolute accuracy goal per bin, relative to a uniform density's share.
    let eps = tol * 4.0 * PI / (theta_bins * phi_bins) as f64;
    for i in 0..theta_bins {
        let t0 = PI * i as f64 / theta_bins as f64;
        let t1 = PI * (i + 1) as f64 / theta_bins as f64;
        let (z0, z1) = (t1.cos(), t0.cos());
        for j in 0..phi_bins {
            let p0 = 2.0 * PI * j as f64 / phi_bins as f64;
            let p1 = 2.0 * PI * (j + 1) as f64 / phi_bins as f64;
            masses.push(integrate_patch(pdf, z0, z1, p0, p1, eps));
        }
    }
    masses
}

/// Estimates ∫_S² pdf(ω) dω by adaptive quadrature on the default grid (for "the pdf integrates to at
/// most 1" checks). Accurate to about 1e-5 for smooth densities and to about 1e-3 for lobes as narrow
/// as a microfacet lobe with α = 0.05.
pub fn sphere_integral(pdf: impl Fn(Vec3) -> f64) -> f64 {
    let o = Chi2Options::default();
    bin_masses(&pdf, o.theta_bins, o.phi_bins, o.quadrature_tolerance)
        .iter()
        .sum()
}

/// The (θ, φ) bin of a direction (θ-major index).
fn bin_of(d: Vec3, theta_bins: usize, phi_bins: usize) -> Option<usize> {
    let d = d.as_dvec3();
    let len = d.length();
    if !(len > 0.5 && len < 1.5) {
        return None;
    }
    let d = d / len;
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let i = ((theta / PI * theta_bins as f64) as usize).min(theta_bins - 1);
    let j = ((phi / (2.0 * PI) * phi_bins as f64) as usize).min(phi_bins - 1);
    Some(i * phi_bins + j)
}

/// Chi-square goodness-of-fit test of a direction sampler against its claimed density (see the crate
/// documentation for the method).
///
/// `sample(u2, u1)` receives uniform random numbers in [0, 1)² and [0, 1) and returns the sampled unit
/// direction with a weight of 1 (binned) or 0 (drawn but not binned, e.g. a delta lobe), or `None` (a
/// rejected sample). Any other weight, or a non-unit direction, makes the test fail. `pdf(ω)` is the
/// density per unit solid angle of the binned samples; its integral over the sphere must therefore equal
/// the expected binned fraction.
pub fn chi2_sphere_test(
    mut sample: impl FnMut(Vec2, f32) -> Option<(Vec3, f32)>,
    pdf: impl Fn(Vec3) -> f64,
    opts: Chi2Options,
) -> Chi2Result {
    let nbins = opts.theta_bins * opts.phi_bins;
    let n = opts.samples as f64;
    let threshold = 1.0 - (1.0 - opts.significance).powf(1.0 / opts.num_tests.max(1) as f64);
    let fail = |message: String, pdf_integral: f64, binned_fraction: f64| Chi2Result {
        passed: false,
        p_value: 0.0,
        threshold,
        statistic: f64::INFINITY,
        dof: 0,
        pdf_integral,
        binned_fraction,
        message,
    };

    // Observed counts; the last cell is "not binned".
    let mut observed = vec![0.0f64; nbins + 1];
    let mut rng = TestRng::new(opts.seed);
    for _ in 0..opts.samples {
        let u2 = Vec2::new(rng.next_f32(), rng.next_f32());
        let u1 = rng.next_f32();
        let Some((d, w)) = sample(u2, u1) else {
            observed[nbins] += 1.0;
            continue;
        };
        if w == 0.0 {
            observed[nbins] += 1.0;
        } else if w == 1.0 {
            match bin_of(d, opts.theta_bins, opts.phi_bins) {
                Some(b) => observed[b] += 1.0,
                None => {
                    return fail(
                        format!("sampled a non-unit direction {d:?}"),
                        f64::NAN,
                        f64::NAN,
                    )
                }
            }
        } else {
            return fail(
                format!("sample weight {w} (direction {d:?}) is neither 0 nor 1"),
                f64::NAN,
                f64::NAN,
            );
        }
    }
    let binned_fraction = 1.0 - observed[nbins] / n;

    let masses = bin_masses(
        &pdf,
        opts.theta_bins,
        opts.phi_bins,
        opts.quadrature_tolerance,
    );
    let pdf_integral: f64 = masses.iter().sum();
    if !pdf_integral.is_finite() {
        return fail(
            "the pdf integral is not finite".into(),
            pdf_integral,
            binned_fraction,
        );
    }

    // Total mass check.
    let p = binned_fraction.clamp(0.0, 1.0);
    let sigma = (p * (1.0 - p) / n).sqrt().max(1.0 / n);
    let mass_tol = opts.integral_tolerance + 5.0 * sigma;
    let mut messages = Vec::new();
    if (pdf_integral - binned_fraction).abs() > mass_tol {
        messages.push(format!(
            "∫pdf = {pdf_integral:.5} differs from the binned sample fraction {binned_fraction:.5} by more than {mass_tol:.1e}"
        ));
    }

    // Expected counts and pooling of sparse cells.
    let mut expected: Vec<f64> = masses.iter().map(|m| m * n).collect();
    expected.push((n - expected.iter().sum::<f64>()).max(0.0));
    let mut cells: Vec<(f64, f64)> = Vec::new();
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    for (e, o) in expected.iter().zip(&observed) {
        if *e < opts.min_expected {
            pool_e += e;
            pool_o += o;
        } else {
            cells.push((*e, *o));
        }
    }
    if pool_e >= opts.min_expected {
        cells.push((pool_e, pool_o));
    } else if pool_o > 0.0 {
        if pool_e > 0.0 && !cells.is_empty() {
            // Fold the residual pool into the smallest cell so that its samples are still tested.
            let k = (0..cells.len())
                .min_by(|&a, &b| cells[a].0.total_cmp(&cells[b].0))
                .unwrap_or(0);
            cells[k].0 += pool_e;
            cells[k].1 += pool_o;
        } else if pool_o > (5.0 * opts.min_expected).max(1e-4 * n) {
            messages.push(format!(
                "{pool_o} samples fell where the pdf is (nearly) zero"
            ));
        }
    }

    let statistic: f64 = cells.iter().map(|(e, o)| (o - e) * (o - e) / e).sum();
    let dof = cells.len().saturating_sub(1);
    let p_value = if dof == 0 {
        1.0
    } else {
        match ChiSquared::new(dof as f64) {
            Ok(d) => d.sf(statistic),
            Err(_) => 0.0,
        }
    };
    if p_value < threshold {
        messages.push(format!(
            "p-value {p_value:.3e} below the threshold {threshold:.3e}"
        ));
    }
    Chi2Result {
        passed: messages.is_empty(),
        p_value,
        threshold,
        statistic,
        dof,
        pdf_integral,
        binned_fraction,
        message: messages.join("; "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cosine_sample(u: Vec2) -> Vec3 {
        let r = u.x.sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.y;
        Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
    }

    fn cosine_pdf(d: Vec3) -> f64 {
        (d.z.max(0.0) as f64) / PI
    }

    #[test]
    fn accepts_a_correct_sampler() {
        let r = chi2_sphere_test(
            |u, _| Some((cosine_sample(u), 1.0)),
            cosine_pdf,
            Chi2Options::default(),
        );
        assert!(r.passed, "{r}");
        assert!((r.pdf_integral - 1.0).abs() < 1e-4, "{r}");
    }

    #[test]
    fn rejects_a_wrong_density() {
        // Uniform hemisphere samples against a cosine density.
        let r = chi2_sphere_test(
            |u, _| {
                let z = u.x;
                let s = (1.0 - z * z).sqrt();
                let phi = 2.0 * std::f32::consts::PI * u.y;
                Some((Vec3::new(s * phi.cos(), s * phi.sin(), z), 1.0))
            },
            cosine_pdf,
            Chi2Options::default(),
        );
        assert!(!r.passed, "{r}");
    }

    #[test]
    fn rejects_a_slightly_wrong_density() {
        // A cosine lobe whose pdf claims a 3 % stronger forward peak.
        let r = chi2_sphere_test(
            |u, _| Some((cosine_sample(u), 1.0)),
            |d| {
                let z = d.z.max(0.0) as f64;
                // Normalised density ∝ z^1.06.
                z.powf(1.06) * 3.06 / (2.0 * PI)
            },
            Chi2Options::default(),
        );
        assert!(!r.passed, "{r}");
    }

    #[test]
    fn accounts_for_unbinned_mass() {
        // 30 % of the samples go to a "delta lobe": the pdf integrates to 0.7.
        let r = chi2_sphere_test(
            |u, u1| {
                if u1 < 0.3 {
                    Some((Vec3::Z, 0.0))
                } else {
                    Some((cosine_sample(u), 1.0))
                }
            },
            |d| 0.7 * cosine_pdf(d),
            Chi2Options::default(),
        );
        assert!(r.passed, "{r}");
        // The same samples against a pdf that forgets the lost mass must fail.
        let r = chi2_sphere_test(
            |u, u1| {
                if u1 < 0.3 {
                    None
                } else {
                    Some((cosine_sample(u), 1.0))
                }
            },
            cosine_pdf,
            Chi2Options::default(),
        );
        assert!(!r.passed, "{r}");
    }

    #[test]
    fn integrates_a_narrow_lobe() {
        // Normalised von Mises–Fisher lobe with κ = 2000 (≈ 1.3° wide) around a tilted axis.
        let axis = Vec3::new(0.3, -0.2, 0.9).normalize();
        let kappa = 2000.0f64;
        let norm = kappa / (2.0 * PI * (1.0 - (-2.0 * kappa).exp()));
        let integral = sphere_integral(|d| norm * (kappa * (axis.dot(d) as f64 - 1.0)).exp());
        assert!((integral - 1.0).abs() < 2e-3, "{integral}");
    }
}
