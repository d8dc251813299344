//! Warps from the unit square to common sampling domains, with their densities.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// Uniform point on the unit disk (Shirley–Chiu concentric map, low distortion).
#[inline]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let a = 2.0 * u.x - 1.0;
    let b = 2.0 * u.y - 1.0;
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let (r, phi) = if a * a > b * b {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, FRAC_PI_2 - FRAC_PI_4 * (a / b))
    };
    Vec2::new(r * phi.cos(), r * phi.sin())
}

/// Cosine-weighted direction on the +Z hemisphere.
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let p = square_to_uniform_disk_concentric(u);
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    Vec3::new(p.x, p.y, z)
}

/// Density of [`square_to_cosine_hemisphere`] per unit solid angle.
#[inline]
pub fn square_to_cosine_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z > 0.0 {
        v.z * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.x;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`square_to_uniform_sphere`] per unit solid angle.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the cone of directions within angle acos(`cos_max`) of +Z.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = 1.0 - u.y * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u.x;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Density of [`square_to_uniform_cone`] per unit solid angle.
#[inline]
pub fn square_to_uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentric coordinates (b1, b2) on a triangle; b0 = 1 - b1 - b2.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    // Heitz 2019, "A low-distortion map between triangle and square".
    if u.y > u.x {
        let b0 = u.x * 0.5;
        let b1 = u.y - b0;
        Vec2::new(b0, b1)
    } else {
        let b1 = u.y * 0.5;
        let b0 = u.x - b1;
        Vec2::new(b0, b1)
    }
}
