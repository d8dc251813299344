//! Analytic open cylinders (Mitsuba `cylinder`): the unit-radius tube around local +Z from z = 0 to 1,
//! without end caps, under an affine map (radius and length come from the map's scale).

use super::{Aabb, PositionSample};
use glam::{Affine3A, DVec3, Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// An open cylinder in world space given by its local-to-world map. Normals point away from the axis
/// unless flipped.
#[derive(Clone, Copy, Debug)]
pub struct Cylinder {
    to_world: Affine3A,
    to_local: Affine3A,
    /// Inverse transpose of the linear part, for normals.
    normal_matrix: Mat3,
    flip_normals: bool,
    area: f32,
}

impl Cylinder {
    /// A cylinder from its object-to-world map. As Mitsuba, the map must scale the two radial axes
    /// equally and must not shear (so that the cylinder stays circular and area sampling stays uniform);
    /// otherwise the error says why.
    pub fn new(to_world: Affine3A, flip_normals: bool) -> Result<Self, String> {
        let (x, y, z) = (
            to_world.matrix3.x_axis,
            to_world.matrix3.y_axis,
            to_world.matrix3.z_axis,
        );
        let (r, ry, len) = (x.length(), y.length(), z.length());
        if !(r > 0.0 && len > 0.0 && r.is_finite() && len.is_finite()) {
            return Err("degenerate cylinder (zero radius or length)".into());
        }
        if (r - ry).abs() > 1e-4 * r {
            return Err(format!(
                "a cylinder's radial axes must be scaled equally (found {r} and {ry})"
            ));
        }
        let tol = 1e-4;
        if (x.dot(y) / (r * ry)).abs() > tol
            || (x.dot(z) / (r * len)).abs() > tol
            || (y.dot(z) / (ry * len)).abs() > tol
        {
            return Err("a cylinder's transform must not shear".into());
        }
        Ok(Cylinder {
            to_world,
            to_local: to_world.inverse(),
            normal_matrix: Mat3::from(to_world.matrix3).inverse().transpose(),
            flip_normals,
            area: 2.0 * PI * r * len,
        })
    }

    /// Nearest hit parameter in (t_min, t_max), if any. Solved in f64 in the local frame (an affine map
    /// keeps the ray parameter) with the numerically stable quadratic.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let lo = self.to_local.transform_point3(o).as_dvec3();
        let ld = self.to_local.transform_vector3(d).as_dvec3();
        let a = ld.x * ld.x + ld.y * ld.y;
        if a == 0.0 {
            return None;
        }
        let b = 2.0 * (lo.x * ld.x + lo.y * ld.y);
        let c = lo.x * lo.x + lo.y * lo.y - 1.0;
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let (mut t0, mut t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let inside = |t: f64| {
            let tf = t as f32;
            let z = lo.z + ld.z * t;
            tf > t_min && tf < t_max && (0.0..=1.0).contains(&z)
        };
        if inside(t0) {
            Some(t0 as f32)
        } else if inside(t1) {
            Some(t1 as f32)
        } else {
            None
        }
    }

    /// The local point of world point `p`, moved radially onto the surface.
    fn local_on_surface(&self, p: Vec3) -> DVec3 {
        let l = self.to_local.transform_point3(p).as_dvec3();
        let r = (l.x * l.x + l.y * l.y).sqrt();
        if r > 0.0 {
            DVec3::new(l.x / r, l.y / r, l.z.clamp(0.0, 1.0))
        } else {
            DVec3::new(1.0, 0.0, l.z.clamp(0.0, 1.0))
        }
    }

    fn normal_at_local(&self, l: DVec3) -> Vec3 {
        let n = (self.normal_matrix * Vec3::new(l.x as f32, l.y as f32, 0.0)).normalize();
        if self.flip_normals {
            -n
        } else {
            n
        }
    }

    /// Surface data at a hit point: the point projected onto the surface, the unit normal, uv
    /// (u = φ/2π, v = z, as Mitsuba) and the tangent ∂p/∂u.
    pub fn surface(&self, p: Vec3) -> (Vec3, Vec3, Vec2, Vec3) {
        let l = self.local_on_surface(p);
        let mut phi = l.y.atan2(l.x) as f32;
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let tangent = self
            .to_world
            .transform_vector3(Vec3::new(-l.y as f32, l.x as f32, 0.0));
        (
            self.to_world.transform_point3(l.as_vec3()),
            self.normal_at_local(l),
            Vec2::new(phi / (2.0 * PI), l.z as f32),
            tangent,
        )
    }

    /// The partial derivatives (∂p/∂u, ∂p/∂v) of the surface at world point `p` for the uv of
    /// [`Cylinder::surface`] (u = φ/2π, v = z).
    pub fn uv_partials(&self, p: Vec3) -> (Vec3, Vec3) {
        let l = self.local_on_surface(p);
        (
            self.to_world
                .transform_vector3(Vec3::new(-l.y as f32, l.x as f32, 0.0) * (2.0 * PI)),
            self.to_world.transform_vector3(Vec3::Z),
        )
    }

    /// Surface area 2π·r·length.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Bounding box (of the local box [-1, 1]² × [0, 1] mapped to the world).
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { 0.0 } else { 1.0 },
            );
            b.expand(self.to_world.transform_point3(c));
        }
        b
    }

    /// Samples a point uniformly by area: φ and z uniform (the map scales both radial axes equally).
    pub fn sample_position(&self, u: Vec2) -> PositionSample {
        let phi = 2.0 * PI * u.x;
        let l = DVec3::new(phi.cos() as f64, phi.sin() as f64, u.y as f64);
        PositionSample {
            p: self.to_world.transform_point3(l.as_vec3()),
            n: self.normal_at_local(l),
            pdf_area: 1.0 / self.area,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    fn cyl() -> Cylinder {
        // Radius 2, length 3, axis along world +X, base at (1, 0, 0).
        let m = Affine3A::from_translation(Vec3::X)
            * Affine3A::from_quat(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2))
            * Affine3A::from_scale(Vec3::new(2.0, 2.0, 3.0));
        Cylinder::new(m, false).unwrap()
    }

    #[test]
    fn hits_from_outside_and_inside() {
        let c = cyl();
        // From above, towards the axis at x = 2: hits the outer wall at y = 2.
        let t = c
            .intersect(Vec3::new(2.0, 5.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 3.0).abs() < 1e-5, "{t}");
        let (p, n, uv, _) = c.surface(Vec3::new(2.0, 5.0 - t, 0.0));
        assert!((p - Vec3::new(2.0, 2.0, 0.0)).length() < 1e-5);
        assert!((n - Vec3::Y).length() < 1e-5, "{n}");
        assert!((uv.y - 1.0 / 3.0).abs() < 1e-5);
        // From the axis: the far wall.
        let t = c
            .intersect(Vec3::new(2.0, 0.0, 0.0), Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 2.0).abs() < 1e-5);
        // Beyond the ends (open tube): misses.
        assert!(c
            .intersect(Vec3::new(4.5, 5.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY)
            .is_none());
        assert!(c
            .intersect(Vec3::new(0.5, 5.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY)
            .is_none());
        // Along the axis: never hits the wall.
        assert!(c
            .intersect(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY)
            .is_none());
        assert!((c.area() - 2.0 * PI * 2.0 * 3.0).abs() < 1e-3);
    }

    #[test]
    fn samples_lie_on_the_surface_with_outward_normals() {
        let c = cyl();
        for i in 0..64 {
            let u = Vec2::new((i as f32 + 0.5) / 64.0, ((i * 37) % 64) as f32 / 64.0);
            let s = c.sample_position(u);
            let radial = Vec3::new(0.0, s.p.y, s.p.z);
            assert!((radial.length() - 2.0).abs() < 1e-4);
            assert!(s.p.x >= 1.0 - 1e-5 && s.p.x <= 4.0 + 1e-5);
            assert!((s.n - radial / 2.0).length() < 1e-4);
        }
    }

    #[test]
    fn rejects_elliptic_and_sheared_maps() {
        assert!(Cylinder::new(Affine3A::from_scale(Vec3::new(1.0, 2.0, 1.0)), false).is_err());
        let shear = Affine3A::from_cols(
            Vec3::X.into(),
            Vec3::new(0.5, 1.0, 0.0).into(),
            Vec3::Z.into(),
            Vec3::ZERO.into(),
        );
        assert!(Cylinder::new(shear, false).is_err());
        assert!(Cylinder::new(Affine3A::from_scale(Vec3::new(1.0, 1.0, 0.0)), false).is_err());
    }
}
