//! Analytic disks (Mitsuba `disk`): the unit disk in the local z = 0 plane, normal +Z, under an affine map.

use super::{Aabb, PositionSample};
use crate::warp::square_to_uniform_disk_concentric;
use glam::{Affine3A, Vec2, Vec3};
use std::f32::consts::PI;

/// A disk in world space given by its local-to-world affine map.
#[derive(Clone, Copy, Debug)]
pub struct Disk {
    to_world: Affine3A,
    to_local: Affine3A,
    normal: Vec3,
    area: f32,
}

impl Disk {
    /// A disk from its object-to-world transform (may scale non-uniformly: an ellipse).
    /// Returns `None` for a degenerate (zero-area) map.
    pub fn new(to_world: Affine3A, flip_normals: bool) -> Option<Self> {
        let du = to_world.transform_vector3(Vec3::X);
        let dv = to_world.transform_vector3(Vec3::Y);
        let cross = du.cross(dv);
        let area = PI * cross.length();
        if !(area > 0.0) || to_world.matrix3.determinant() == 0.0 {
            return None;
        }
        let n = cross.normalize();
        Some(Disk {
            to_world,
            to_local: to_world.inverse(),
            normal: if flip_normals { -n } else { n },
            area,
        })
    }

    /// Hit parameter in (t_min, t_max), if any.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let lo = self.to_local.transform_point3(o);
        let ld = self.to_local.transform_vector3(d);
        if ld.z == 0.0 {
            return None;
        }
        let t = -lo.z / ld.z;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let p = lo + ld * t;
        if p.x * p.x + p.y * p.y <= 1.0 {
            Some(t)
        } else {
            None
        }
    }

    /// Unit normal (constant over the disk).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// Polar uv (u = r, v = φ/2π, as Mitsuba's disk).
    pub fn uv(&self, p: Vec3) -> Vec2 {
        let l = self.to_local.transform_point3(p);
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        Vec2::new((l.x * l.x + l.y * l.y).sqrt(), phi / (2.0 * PI))
    }

    /// The partial derivatives (∂p/∂u, ∂p/∂v) of the surface at `p` for [`Disk::uv`] (u = r, v = φ/2π).
    pub fn uv_partials(&self, p: Vec3) -> (Vec3, Vec3) {
        let l = self.to_local.transform_point3(p);
        let r = (l.x * l.x + l.y * l.y).sqrt();
        let (cos_phi, sin_phi) = if r > 1e-7 {
            (l.x / r, l.y / r)
        } else {
            (1.0, 0.0)
        };
        (
            self.to_world
                .transform_vector3(Vec3::new(cos_phi, sin_phi, 0.0)),
            self.to_world
                .transform_vector3(Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI)),
        )
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            b.expand(self.to_world.transform_point3(Vec3::new(x, y, 0.0)));
        }
        b
    }

    /// Samples a point uniformly by area (an affine map keeps area ratios).
    pub fn sample_position(&self, u: Vec2) -> PositionSample {
        let q = square_to_uniform_disk_concentric(u);
        let p = self.to_world.transform_point3(Vec3::new(q.x, q.y, 0.0));
        PositionSample {
            p,
            n: self.normal,
            pdf_area: 1.0 / self.area,
        }
    }
}
