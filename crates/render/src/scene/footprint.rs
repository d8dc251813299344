//! The uv footprint of a camera ray's pixel sample at its first hit (Mitsuba 0.6's
//! `Intersection::computePartials`): the offset rays of the ray differential are intersected with the
//! hit's tangent plane and the uv coordinates of those points, from the shape's local parameterisation,
//! give ∂uv/∂x and ∂uv/∂y.

use super::Scene;
use crate::geometry::{ShapeGeometry, SurfaceInteraction};
use crate::ray::RayDifferential;
use crate::texture::UvFootprint;
use glam::{Vec2, Vec3};

impl Scene {
    /// The uv footprint at `si` of a pixel sample with differential `diff`; zero when an offset ray
    /// runs parallel to the tangent plane or the result is not finite.
    pub fn uv_footprint(&self, si: &SurfaceInteraction, diff: &RayDifferential) -> UvFootprint {
        let n = si.ng;
        let on_plane = |o: Vec3, d: Vec3| -> Option<Vec3> {
            let denom = n.dot(d);
            if denom == 0.0 {
                return None;
            }
            let t = n.dot(si.p - o) / denom;
            Some(o + d * t)
        };
        let (Some(px), Some(py)) = (
            on_plane(diff.rx_o, diff.rx_d),
            on_plane(diff.ry_o, diff.ry_d),
        ) else {
            return UvFootprint::default();
        };
        let fp = UvFootprint {
            duv_dx: self.uv_offset(si, px),
            duv_dy: self.uv_offset(si, py),
        };
        if fp.duv_dx.is_finite() && fp.duv_dy.is_finite() {
            fp
        } else {
            UvFootprint::default()
        }
    }

    /// uv(q) − uv(si) for a point `q` on the tangent plane near the hit, to first order.
    fn uv_offset(&self, si: &SurfaceInteraction, q: Vec3) -> Vec2 {
        // Periodic coordinates that wrap around at 1: take the shorter way.
        let wrap = |d: f32| d - d.round();
        match &self.geometries[si.shape as usize] {
            ShapeGeometry::Mesh(m) => {
                // Barycentrics of q in the triangle's plane (the linear map extends past its edges).
                let [a, b, c] = m.indices[si.prim as usize].map(|k| m.positions[k as usize]);
                let (e1, e2, r) = (b - a, c - a, q - a);
                let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                let (r1, r2) = (r.dot(e1), r.dot(e2));
                let det = d11 * d22 - d12 * d12;
                if !(det.abs() > 0.0) {
                    return Vec2::ZERO;
                }
                let bary = Vec2::new(d22 * r1 - d12 * r2, d11 * r2 - d12 * r1) / det;
                m.uv(si.prim as usize, bary) - si.uv
            }
            ShapeGeometry::Sphere(s) => {
                let d = s.uv(q) - si.uv;
                Vec2::new(wrap(d.x), d.y)
            }
            ShapeGeometry::Disk(disk) => {
                let d = disk.uv(q) - si.uv;
                Vec2::new(d.x, wrap(d.y))
            }
            ShapeGeometry::Cylinder(c) => {
                let d = c.surface(q).2 - si.uv;
                Vec2::new(wrap(d.x), d.y)
            }
        }
    }
}
