//! The thin-lens camera: a pinhole projection whose rays start on a circular aperture and converge on
//! the focus plane (Mitsuba 3 `thinlens`).

use super::projection::Projection;
use crate::ray::Ray;
use crate::warp::square_to_uniform_disk_concentric;
use glam::{Vec2, Vec3};

/// A thin lens of radius `aperture_radius` focused at camera-space depth `focus_distance`.
#[derive(Clone, Debug)]
pub struct ThinLens {
    projection: Projection,
    aperture_radius: f32,
    focus_distance: f32,
}

impl ThinLens {
    /// A thin lens over `projection`. A zero radius behaves as a pinhole.
    pub fn new(projection: Projection, aperture_radius: f32, focus_distance: f32) -> Self {
        ThinLens {
            projection,
            aperture_radius,
            focus_distance,
        }
    }

    /// The underlying pinhole projection.
    pub fn projection(&self) -> &Projection {
        &self.projection
    }

    /// Radius of the aperture in scene units.
    pub fn aperture_radius(&self) -> f32 {
        self.aperture_radius
    }

    /// Distance from the lens to the plane in focus, along the viewing axis.
    pub fn focus_distance(&self) -> f32 {
        self.focus_distance
    }

    /// See [`super::Camera::generate_ray`].
    #[inline]
    pub fn generate_ray(&self, film_pos: Vec2, aperture_u: Vec2) -> Ray {
        let p = &self.projection;
        let focus_p = p.film_to_local_plane(film_pos) * self.focus_distance;
        let lens = self.aperture_radius * square_to_uniform_disk_concentric(aperture_u);
        let aperture_p = Vec3::new(lens.x, lens.y, 0.0);
        let d = (focus_p - aperture_p).normalize();
        let inv_z = 1.0 / d.z;
        let d_world = p.dir_to_world(d);
        let near_t = p.near_clip() * inv_z;
        let far_t = p.far_clip() * inv_z;
        let o = p.to_world().transform_point3(aperture_p) + d_world * near_t;
        Ray::segment(o, d_world, far_t - near_t)
    }

    /// The world-space lens point of `aperture_u` and the (unnormalised) world directions from it
    /// towards the focus-plane points of the film positions one pixel right of and below `film_pos`.
    pub(super) fn differential_rays(&self, film_pos: Vec2, aperture_u: Vec2) -> (Vec3, Vec3, Vec3) {
        let p = &self.projection;
        let lens = self.aperture_radius * square_to_uniform_disk_concentric(aperture_u);
        let aperture_p = Vec3::new(lens.x, lens.y, 0.0);
        let towards =
            |f: Vec2| p.dir_to_world(p.film_to_local_plane(f) * self.focus_distance - aperture_p);
        (
            p.to_world().transform_point3(aperture_p),
            towards(film_pos + Vec2::X),
            towards(film_pos + Vec2::Y),
        )
    }
}
