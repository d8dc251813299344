//! Fresnel reflectance of dielectric and conductor interfaces, and reflection/refraction in the local
//! frame (Mitsuba 3 `fresnel.h`).

use crate::color::Rgb;
use glam::Vec3;

/// Fresnel reflectance of a dielectric interface with relative IOR `eta` (interior over exterior, the
/// normal pointing to the exterior) for incidence `cos_theta_i` (negative: from the interior).
#[derive(Clone, Copy, Debug)]
pub struct DielectricFresnel {
    /// Unpolarised reflectance F.
    pub f: f32,
    /// Signed cosine of the transmitted direction (opposite sign to `cos_theta_i`; 0 under total
    /// internal reflection).
    pub cos_theta_t: f32,
    /// Relative IOR in the direction of travel (transmitted over incident medium).
    pub eta_it: f32,
    /// Its reciprocal, the tangential scale of the refracted direction.
    pub eta_ti: f32,
}

/// Unpolarised Fresnel reflectance of a dielectric interface (see [`DielectricFresnel`]).
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> DielectricFresnel {
    let outside = cos_theta_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let (eta_it, eta_ti) = if outside {
        (eta, rcp_eta)
    } else {
        (rcp_eta, eta)
    };
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let cos_i = cos_theta_i.abs();
    let cos_t = cos_theta_t_sqr.max(0.0).sqrt();
    let f = if eta == 1.0 {
        0.0
    } else if cos_i == 0.0 {
        1.0
    } else {
        let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
        let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
        (0.5 * (a_s * a_s + a_p * a_p)).min(1.0)
    };
    let cos_theta_t = if cos_theta_i >= 0.0 { -cos_t } else { cos_t };
    DielectricFresnel {
        f,
        cos_theta_t,
        eta_it,
        eta_ti,
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative IOR `eta + i k`, per channel,
/// for light arriving from outside (`cos_theta_i` ≥ 0). Exact formula (Moeller, "Optics", 1988).
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    let c2 = cos_theta_i * cos_theta_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp_1 = eta * eta - k * k - Rgb::splat(s2);
    let a2pb2 = (temp_1 * temp_1 + 4.0 * k * k * eta * eta)
        .max(Rgb::ZERO)
        .powf(0.5);
    let a = (0.5 * (a2pb2 + temp_1)).max(Rgb::ZERO).powf(0.5);
    let term_1 = a2pb2 + Rgb::splat(c2);
    let term_2 = 2.0 * cos_theta_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2).max(Rgb::splat(1e-20));
    let term_3 = a2pb2 * c2 + Rgb::splat(s4);
    let term_4 = term_2 * s2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4).max(Rgb::splat(1e-20));
    (0.5 * (r_s + r_p)).clamp(Rgb::ZERO, Rgb::ONE)
}

/// Hemispherical average of the dielectric Fresnel reflectance for diffuse illumination ("Fdr"), using
/// the same fits as Mitsuba: Egan & Hilgeman (1973) for η < 1 and d'Eon & Irving (2011) otherwise.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let i1 = 1.0 / eta;
        let i2 = i1 * i1;
        let i3 = i2 * i1;
        let i4 = i3 * i1;
        let i5 = i4 * i1;
        0.919317 - 3.4793 * i1 + 6.75335 * i2 - 7.80989 * i3 + 4.98554 * i4 - 1.36881 * i5
    }
}

/// Mirror reflection about the local normal +Z.
#[inline]
pub fn reflect(wi: Vec3) -> Vec3 {
    Vec3::new(-wi.x, -wi.y, wi.z)
}

/// Mirror reflection about a microfacet normal `m`.
#[inline]
pub fn reflect_about(wi: Vec3, m: Vec3) -> Vec3 {
    m * (2.0 * wi.dot(m)) - wi
}

/// Refraction through the local +Z interface, given `cos_theta_t` and `eta_ti` from
/// [`fresnel_dielectric`].
#[inline]
pub fn refract(wi: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    Vec3::new(-eta_ti * wi.x, -eta_ti * wi.y, cos_theta_t)
}

/// Refraction through a microfacet with normal `m`, given `cos_theta_t` and `eta_ti` from
/// [`fresnel_dielectric`] evaluated at `wi · m`.
#[inline]
pub fn refract_about(wi: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_theta_t) - wi * eta_ti
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_normal_incidence() {
        let f = fresnel_dielectric(1.0, 1.5);
        assert!((f.f - 0.04).abs() < 1e-6);
        assert!((f.cos_theta_t + 1.0).abs() < 1e-6);
        // From inside, beyond the critical angle: total internal reflection.
        let f = fresnel_dielectric(-0.1, 1.5);
        assert_eq!(f.f, 1.0);
    }

    #[test]
    fn conductor_none_is_a_mirror_and_matches_dielectric_for_k0() {
        for c in [0.05f32, 0.3, 0.7, 1.0] {
            let f = fresnel_conductor(c, Rgb::ZERO, Rgb::ONE);
            assert!((f - Rgb::ONE).abs().max_element() < 1e-5, "{f}");
            let fc = fresnel_conductor(c, Rgb::splat(1.5), Rgb::ZERO);
            let fd = fresnel_dielectric(c, 1.5).f;
            assert!((fc.x - fd).abs() < 1e-5, "{c}: {fc} vs {fd}");
        }
    }

    #[test]
    fn diffuse_reflectance_matches_integral() {
        for eta in [1.33f32, 1.5, 1.0 / 1.5] {
            let n = 20000;
            let mut s = 0.0f64;
            for i in 0..n {
                let mu = (i as f64 + 0.5) / n as f64;
                s += fresnel_dielectric(mu as f32, eta).f as f64 * mu * 2.0 / n as f64;
            }
            assert!(
                (s - fresnel_diffuse_reflectance(eta) as f64).abs() < 5e-3,
                "{eta}: {s}"
            );
        }
    }
}
