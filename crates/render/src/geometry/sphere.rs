//! Analytic spheres (Mitsuba `sphere`), with visible-cone sampling for spherical lights.

use super::{Aabb, PositionSample};
use crate::frame::Frame;
use crate::warp::{square_to_uniform_cone, square_to_uniform_cone_pdf, square_to_uniform_sphere};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A sphere in world space; normals point outwards unless flipped.
#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
    /// Whether normals point inwards (`flip_normals`).
    pub flip_normals: bool,
}

impl Sphere {
    /// Nearest hit parameter in (t_min, t_max), if any. Uses the numerically stable form of the quadratic
    /// (Ray Tracing Gems ch. 7) in f64, since small lights far away are common in our scenes.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let f = (o - self.center).as_dvec3();
        let d = d.as_dvec3();
        let r = self.radius as f64;
        let a = d.length_squared();
        let b = -f.dot(d);
        let l = f + d * (b / a);
        let disc = r * r - l.length_squared();
        if disc < 0.0 {
            return None;
        }
        let c = f.length_squared() - r * r;
        let q = b + b.signum() * (a * disc).sqrt();
        if q == 0.0 {
            return None;
        }
        let (mut t0, mut t1) = (c / q, q / a);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let (t0, t1) = (t0 as f32, t1 as f32);
        if t0 > t_min && t0 < t_max {
            Some(t0)
        } else if t1 > t_min && t1 < t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// Outward (or flipped) unit normal at surface point `p`.
    #[inline]
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let n = (p - self.center).normalize();
        if self.flip_normals {
            -n
        } else {
            n
        }
    }

    /// Projects a hit point exactly onto the surface (removes the error of `o + t d`).
    #[inline]
    pub fn project(&self, p: Vec3) -> Vec3 {
        self.center + (p - self.center).normalize() * self.radius
    }

    /// Spherical uv (u = φ/2π, v = θ/π around local +Z, as Mitsuba's sphere).
    #[inline]
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let l = (p - self.center) / self.radius;
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        Vec2::new(phi / (2.0 * PI), l.z.clamp(-1.0, 1.0).acos() / PI)
    }

    /// The partial derivatives (∂p/∂u, ∂p/∂v) of the surface at `p` for [`Sphere::uv`] (as Mitsuba 3's
    /// sphere; ∂p/∂v is along the meridian at the poles, where φ is undefined).
    pub fn uv_partials(&self, p: Vec3) -> (Vec3, Vec3) {
        let l = p - self.center;
        let rho = (l.x * l.x + l.y * l.y).sqrt();
        let (cos_phi, sin_phi) = if rho > 1e-7 * self.radius {
            (l.x / rho, l.y / rho)
        } else {
            (1.0, 0.0)
        };
        (
            Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI),
            Vec3::new(l.z * cos_phi, l.z * sin_phi, -rho) * PI,
        )
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.center - Vec3::splat(self.radius),
            max: self.center + Vec3::splat(self.radius),
        }
    }

    /// Samples a point uniformly by area.
    pub fn sample_position(&self, u: Vec2) -> PositionSample {
        let d = square_to_uniform_sphere(u);
        let p = self.center + d * self.radius;
        PositionSample {
            p,
            n: if self.flip_normals { -d } else { d },
            pdf_area: 1.0 / self.area(),
        }
    }

    /// Samples a direction from `x` towards the sphere. Outside the sphere the cone of visible directions is
    /// sampled uniformly; returns (direction, distance to the first hit, solid-angle pdf). Inside, a point is
    /// sampled by area and converted. `None` if the sample misses due to round-off.
    pub fn sample_direction(&self, x: Vec3, u: Vec2) -> Option<(Vec3, f32, f32)> {
        let dc = self.center - x;
        let dist2 = dc.length_squared();
        let r2 = self.radius * self.radius;
        if dist2 > r2 * (1.0 + 1e-4) {
            let dist = dist2.sqrt();
            let sin2_max = r2 / dist2;
            let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
            let frame = Frame::from_normal(dc / dist);
            let local = square_to_uniform_cone(u, cos_max);
            let d = frame.to_world(local).normalize();
            let t = self.intersect(x, d, 0.0, f32::INFINITY).or_else(|| {
                // Grazing direction at the cone's rim: take the tangent point.
                Some(d.dot(dc).max(0.0))
            })?;
            Some((d, t, square_to_uniform_cone_pdf(cos_max)))
        } else {
            let ps = self.sample_position(u);
            let v = ps.p - x;
            let d2 = v.length_squared();
            if d2 == 0.0 {
                return None;
            }
            let dist = d2.sqrt();
            let d = v / dist;
            let cos = ps.n.dot(d).abs();
            if cos <= 0.0 {
                return None;
            }
            Some((d, dist, ps.pdf_area * d2 / cos))
        }
    }

    /// Solid-angle pdf of [`Sphere::sample_direction`] producing direction `d` from `x` whose hit lies at
    /// point `p` (with normal `n`).
    pub fn pdf_direction(&self, x: Vec3, p: Vec3, n: Vec3) -> f32 {
        let dc = self.center - x;
        let dist2 = dc.length_squared();
        let r2 = self.radius * self.radius;
        if dist2 > r2 * (1.0 + 1e-4) {
            let cos_max = (1.0 - r2 / dist2).max(0.0).sqrt();
            square_to_uniform_cone_pdf(cos_max)
        } else {
            let v = p - x;
            let d2 = v.length_squared();
            let cos = n.dot(v).abs() / d2.sqrt();
            if cos <= 0.0 {
                return 0.0;
            }
            d2 / (cos * self.area())
        }
    }
}
