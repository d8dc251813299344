//! The GMM guide's sampling distribution at a shading point: the `f32` kernel's per-component terms
//! and hemisphere masses, computed once per point ([`GmmDistribution`]), and sampling and pdf from them.

use glam::{DVec3, Vec3};

use super::cumulative::pick_interval;
use super::guide::{unit, GmmGuide};
use super::mixture::{MAX_COMPONENTS, TERMS_PER_COMPONENT};
use super::special::open_unit;
use super::truncated::sample_half_space;
pub use crate::sampling::GmmDistribution;
use crate::GuideSample;

/// With a `normal`, a hemisphere holding less guide mass than this is treated as empty (`sample`
/// returns `None`, `pdf` 0): guiding into it would only chase the mixture's far tails.
pub const MIN_HEMISPHERE_MASS: f64 = 1e-6;
/// `f32` kernel terms per mixture in a [`GmmDistribution`]: the converging mixture's block, then the
/// diverging one's.
const KERNEL_TERMS_BLOCK: usize = TERMS_PER_COMPONENT * MAX_COMPONENTS;

impl GmmGuide {
    /// Computes the unit-frame point, every component's kernel terms and, with a normal, every
    /// component's hemisphere mass once.
    pub(super) fn init_distribution(&self, d: &mut GmmDistribution, x: Vec3, normal: Option<Vec3>) {
        d.xu = self.to_unit(x);
        d.normal = normal.and_then(|n| unit(n.as_dvec3()));
        d.z = 1.0;
        d.active = self.is_trained() && d.xu.is_finite();
        if d.active {
            d.z = self.prepare_kernel(d.xu, d.normal, &mut d.terms, &mut d.masses);
        }
    }

    /// Full sphere: `u[0]` picks the mixture (diverging with probability p_div) and, rescaled, the
    /// component and then the first normal variate; `u[1]`, `u[2]` give the other two (inverse CDF).
    /// With a normal: `u[0]` picks a component among both mixtures in proportion to its mass in the
    /// hemisphere and, rescaled, the truncated normal variate along the normal.
    pub(super) fn sample_distribution(
        &self,
        d: &GmmDistribution,
        u: [f32; 3],
    ) -> Option<GuideSample> {
        if !d.active {
            return None;
        }
        let dir = match d.normal {
            None => self.sample_sphere(d.xu, u)?,
            Some(n) => self.sample_hemisphere(d.xu, n, &d.masses, d.z, u)?,
        };
        self.finish_sample(d, dir)
    }

    /// The `f32` kernel's pdf (see [`GmmGuide::pdf_f64`] for the `f64` reference).
    pub(super) fn distribution_pdf(&self, d: &GmmDistribution, direction: Vec3) -> f32 {
        if !d.active {
            return 0.0;
        }
        let p = self.pdf_given(d.xu, d.normal, direction, d.z, |w| {
            self.full_pdf_prepared(&d.terms, w)
        }) as f32;
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// The untruncated pdf of unit `w` at unit-frame `x`.
    #[inline]
    fn full_pdf(&self, x: DVec3, w: DVec3) -> f64 {
        let q = self.p_div;
        let mut p = 0.0;
        if q < 1.0 {
            p += (1.0 - q) * self.conv.mixture.directional_pdf(x, w);
        }
        if q > 0.0 {
            p += q * self.div.mixture.directional_pdf(x, -w);
        }
        p
    }

    /// The untruncated pdf of unit `w` from the shading point whose kernel terms
    /// ([`GmmGuide::prepare_kernel`]) are `terms`: the renderer's `f32` kernel.
    #[inline]
    fn full_pdf_prepared(&self, terms: &[f32], w: DVec3) -> f64 {
        let q = self.p_div;
        let wf = [w.x as f32, w.y as f32, w.z as f32];
        let (conv, div) = terms.split_at(KERNEL_TERMS_BLOCK);
        let mut p = 0.0;
        if q < 1.0 {
            p += (1.0 - q) * self.conv.mixture.directional_pdf_prepared(conv, wf) as f64;
        }
        if q > 0.0 {
            let back = [-wf[0], -wf[1], -wf[2]];
            p += q * self.div.mixture.directional_pdf_prepared(div, back) as f64;
        }
        p
    }

    /// Fills `terms` (converging mixture first, then diverging, [`KERNEL_TERMS_BLOCK`] values each) with
    /// the per-component terms of the `f32` kernel at unit-frame `x` and, with a unit normal `n`,
    /// `masses` as [`GmmGuide::hemisphere_masses`] does (Φ in `f32`), returning Z (1 without a normal).
    #[inline]
    fn prepare_kernel(
        &self,
        x: DVec3,
        n: Option<DVec3>,
        terms: &mut Vec<f32>,
        masses: &mut Vec<f64>,
    ) -> f64 {
        terms.resize(2 * KERNEL_TERMS_BLOCK, 0.0);
        masses.resize(2 * MAX_COMPONENTS, 0.0);
        let (conv_terms, div_terms) = terms.split_at_mut(KERNEL_TERMS_BLOCK);
        let (conv_masses, div_masses) = masses.split_at_mut(MAX_COMPONENTS);
        let q = self.p_div;
        if q < 1.0 {
            let on_side = n.map(|n| (n, true));
            self.conv
                .mixture
                .prepare_vertex(x, on_side, conv_terms, conv_masses);
        }
        if q > 0.0 {
            let on_side = n.map(|n| (n, false));
            self.div
                .mixture
                .prepare_vertex(x, on_side, div_terms, div_masses);
        }
        match n {
            Some(_) => self.hemisphere_total(masses),
            None => 1.0,
        }
    }

    /// Z = (1 − p_div)·Σ_conv + p_div·Σ_div of the per-component hemisphere masses in `masses`
    /// (converging first, then diverging, [`MAX_COMPONENTS`] entries each).
    #[inline]
    fn hemisphere_total(&self, masses: &[f64]) -> f64 {
        let q = self.p_div;
        let (conv, div) = masses.split_at(MAX_COMPONENTS);
        let mut z = 0.0;
        if q < 1.0 {
            z += (1.0 - q) * conv[..self.conv.mixture.len()].iter().sum::<f64>();
        }
        if q > 0.0 {
            z += q * div[..self.div.mixture.len()].iter().sum::<f64>();
        }
        z
    }

    /// Fills `masses` with every component's share π_kΦ_k (converging, first half) or π_k(1 − Φ_k)
    /// (diverging, second half) of the hemisphere above (x, n), and returns
    /// Z = (1 − p_div)·Σ_conv + p_div·Σ_div (the `f64` reference).
    #[inline]
    fn hemisphere_masses(&self, x: DVec3, n: DVec3, masses: &mut [f64]) -> f64 {
        let q = self.p_div;
        let (conv, div) = masses.split_at_mut(MAX_COMPONENTS);
        if q < 1.0 {
            self.conv.mixture.half_space_masses(x, n, true, conv);
        }
        if q > 0.0 {
            self.div.mixture.half_space_masses(x, n, false, div);
        }
        self.hemisphere_total(masses)
    }

    /// The pdf from the `f64` reference kernel ([`Mixture::directional_pdf`]), which the renderer's
    /// `f32` kernel behind [`crate::GuidingField::pdf`] approximates to about 1e-6 relative. For tests
    /// and tools that check the formula itself.
    pub fn pdf_f64(&self, x: Vec3, normal: Option<Vec3>, d: Vec3) -> f64 {
        if !self.is_trained() {
            return 0.0;
        }
        let xu = self.to_unit(x);
        let n = normal.and_then(|n| unit(n.as_dvec3()));
        let z = match n {
            Some(n) => self.hemisphere_masses(xu, n, &mut [0.0; 2 * MAX_COMPONENTS]),
            None => 1.0,
        };
        self.pdf_given(xu, n, d, z, |w| self.full_pdf(xu, w))
    }

    /// The pdf at `d` from unit-frame `xu`, given the hemisphere mass `z` of the unit normal `n` and the
    /// untruncated pdf `full` of a unit direction (the one computation `pdf` and `sample` share, so their
    /// values agree bit for bit).
    #[inline]
    fn pdf_given(
        &self,
        xu: DVec3,
        n: Option<DVec3>,
        d: Vec3,
        z: f64,
        full: impl Fn(DVec3) -> f64,
    ) -> f64 {
        let Some(w) = unit(d.as_dvec3()) else {
            return 0.0;
        };
        if !xu.is_finite() {
            return 0.0;
        }
        match n {
            None => full(w),
            Some(n) => {
                if !(n.dot(w) > 0.0) || !(z >= MIN_HEMISPHERE_MASS) {
                    return 0.0;
                }
                full(w) / z
            }
        }
    }

    /// Samples a unit-frame direction (not yet rounded) from `x` (unit frame) over the whole sphere.
    fn sample_sphere(&self, x: DVec3, u: [f32; 3]) -> Option<DVec3> {
        let u1 = open_unit(u[1] as f64);
        let u2 = open_unit(u[2] as f64);
        let q = self.p_div;
        let u0 = u[0] as f64;
        let diverging = u0 < q;
        let u0 = if diverging {
            u0 / q
        } else {
            (u0 - q) / (1.0 - q)
        };
        let mixture = if diverging {
            &self.div.mixture
        } else {
            &self.conv.mixture
        };
        let y = mixture.sample_point([u0.clamp(0.0, 1.0), u1, u2])?;
        Some(if diverging { x - y } else { y - x })
    }

    /// Samples a unit-frame direction (not yet rounded) from `x` (unit frame) in the hemisphere around
    /// unit `n`, given the per-component hemisphere `masses` and their total `z`
    /// ([`GmmGuide::hemisphere_masses`]).
    fn sample_hemisphere(
        &self,
        x: DVec3,
        n: DVec3,
        masses: &[f64],
        z: f64,
        u: [f32; 3],
    ) -> Option<DVec3> {
        if !(z >= MIN_HEMISPHERE_MASS) {
            return None;
        }
        let u1 = open_unit(u[1] as f64);
        let u2 = open_unit(u[2] as f64);
        let q = self.p_div;
        let (kc, kd) = (self.conv.mixture.len(), self.div.mixture.len());
        let shares = masses[..kc].iter().map(|m| (1.0 - q) * m).chain(
            masses[MAX_COMPONENTS..MAX_COMPONENTS + kd]
                .iter()
                .map(|m| q * m),
        );
        let target = u[0] as f64 * z;
        let (i, before, m) = pick_interval(shares, target)?;
        let u0 = open_unit((target - before) / m);
        Some(if i < kc {
            let g = &self.conv.mixture.components()[i];
            sample_half_space(g, x, n, true, [u0, u1, u2]) - x
        } else {
            let g = &self.div.mixture.components()[i - kc];
            x - sample_half_space(g, x, n, false, [u0, u1, u2])
        })
    }

    /// Rounds a unit-frame direction to the `f32` sample and attaches its exact pdf.
    fn finish_sample(&self, d: &GmmDistribution, dir: DVec3) -> Option<GuideSample> {
        let direction = unit(dir)?.as_vec3().normalize_or_zero();
        if direction == Vec3::ZERO {
            return None;
        }
        // Exactly `pdf(x, normal, direction)`, reusing the hemisphere mass and the kernel terms.
        let pdf = self.pdf_given(d.xu, d.normal, direction, d.z, |w| {
            self.full_pdf_prepared(&d.terms, w)
        }) as f32;
        (pdf > 0.0 && pdf.is_finite()).then_some(GuideSample { direction, pdf })
    }
}
