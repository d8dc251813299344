//! Sensors: the perspective pinhole camera and the thin-lens camera of Mitsuba 3.
//!
//! Conventions (Mitsuba 3, see `docs/design/mitsuba-conventions.md`): the camera looks along local +Z,
//! local +Y is up and local +X is the image's *left* (the `lookat` frame has left = up × dir), so image
//! column u grows towards world dir × up and row 0 is the top. Rays start on the near clip plane and stop at the far
//! clip plane. Film positions are continuous pixel coordinates of the full film, (0, 0) being the
//! top-left corner of the top-left pixel (pixel centres at +0.5); a crop window does not change them.

mod fov;
mod projection;
mod thin_lens;

pub use fov::{diagonal_fov_from_focal_length, parse_x_fov, x_fov_from_axis, FovAxis};
pub use projection::{rigid_camera_to_world, Projection};
pub use thin_lens::ThinLens;

use crate::desc::ObjectDesc;
use crate::error::SceneResult;
use crate::ray::{CameraRay, Ray, RayDifferential};
use glam::{Mat4, UVec2, Vec2, Vec3};

/// A camera that turns film positions (and lens samples) into world-space primary rays.
#[derive(Clone, Debug)]
pub enum Camera {
    /// Mitsuba `perspective`: an ideal pinhole.
    Perspective(Projection),
    /// Mitsuba `thinlens`: a pinhole projection with a circular thin lens for depth of field.
    ThinLens(ThinLens),
}

/// Builds the camera of a `<sensor>` for a film of `film_size` pixels (the full film, not the crop).
///
/// Reads `to_world` (must be rigid, see [`rigid_camera_to_world`]), `fov` + `fov_axis` or
/// `focal_length` (see [`parse_x_fov`]), `near_clip` (0.01), `far_clip` (1e4) and, for `thinlens`,
/// `aperture_radius` (required, as in Mitsuba 3) and `focus_distance` (default: `far_clip`).
pub fn camera_from_desc(sensor: &ObjectDesc, film_size: UVec2) -> SceneResult<Camera> {
    if !matches!(sensor.plugin.as_str(), "perspective" | "thinlens") {
        return Err(sensor.error(format!(
            "unsupported sensor type '{}' (supported: perspective, thinlens)",
            sensor.plugin
        )));
    }
    if film_size.x == 0 || film_size.y == 0 {
        return Err(sensor.error(format!(
            "the film size {}x{} is empty",
            film_size.x, film_size.y
        )));
    }
    let to_world = rigid_camera_to_world(sensor)?;
    let aspect = film_size.x as f64 / film_size.y as f64;
    let x_fov = parse_x_fov(sensor, aspect)?;
    let near_clip = sensor.float_or("near_clip", 1e-2)?;
    let far_clip = sensor.float_or("far_clip", 1e4)?;
    if !(near_clip > 0.0 && near_clip.is_finite()) {
        return Err(sensor.error(format!(
            "near_clip must be greater than zero, got {near_clip}"
        )));
    }
    if far_clip.is_nan() || far_clip <= near_clip {
        return Err(sensor.error(format!(
            "near_clip ({near_clip}) must be smaller than far_clip ({far_clip})"
        )));
    }
    let projection = Projection::new(
        to_world,
        film_size,
        x_fov,
        near_clip as f32,
        far_clip as f32,
    );
    match sensor.plugin.as_str() {
        "perspective" => Ok(Camera::Perspective(projection)),
        _ => {
            let Some(aperture_radius) = sensor.float_opt("aperture_radius")? else {
                return Err(sensor.error("thinlens sensor needs an 'aperture_radius'"));
            };
            let focus_distance = sensor.float_or("focus_distance", far_clip)?;
            if !(aperture_radius >= 0.0 && aperture_radius.is_finite()) {
                return Err(sensor.error(format!(
                    "aperture_radius must be non-negative, got {aperture_radius}"
                )));
            }
            if !(focus_distance > 0.0 && focus_distance.is_finite()) {
                return Err(sensor.error(format!(
                    "focus_distance must be positive, got {focus_distance}"
                )));
            }
            Ok(Camera::ThinLens(ThinLens::new(
                projection,
                aperture_radius as f32,
                focus_distance as f32,
            )))
        }
    }
}

impl Camera {
    /// The pinhole projection (frame, field of view, clip planes) of this camera.
    pub fn projection(&self) -> &Projection {
        match self {
            Camera::Perspective(p) => p,
            Camera::ThinLens(t) => t.projection(),
        }
    }

    /// The world-space ray through film position `film_pos` (pixels, (0, 0) = top-left corner of the
    /// image) and lens sample `aperture_u` ∈ [0, 1)² (ignored by the pinhole). The direction is unit
    /// length, the origin lies on the near clip plane and `t_max` ends the ray on the far clip plane.
    #[inline]
    pub fn generate_ray(&self, film_pos: Vec2, aperture_u: Vec2) -> Ray {
        match self {
            Camera::Perspective(p) => {
                let d = p.film_to_local_plane(film_pos).normalize();
                let inv_z = 1.0 / d.z;
                let d_world = p.dir_to_world(d);
                let near_t = p.near_clip() * inv_z;
                let far_t = p.far_clip() * inv_z;
                Ray::segment(p.position() + d_world * near_t, d_world, far_t - near_t)
            }
            Camera::ThinLens(t) => t.generate_ray(film_pos, aperture_u),
        }
    }

    /// [`Camera::generate_ray`] with the differentials of a one-pixel step along x and y (the offset
    /// rays share the lens sample), for texture filtering at the first hit.
    #[inline]
    pub fn generate_ray_differential(&self, film_pos: Vec2, aperture_u: Vec2) -> CameraRay {
        let ray = self.generate_ray(film_pos, aperture_u);
        let (origin, dx, dy) = match self {
            Camera::Perspective(p) => (
                p.position(),
                p.dir_to_world(p.film_to_local_plane(film_pos + Vec2::X)),
                p.dir_to_world(p.film_to_local_plane(film_pos + Vec2::Y)),
            ),
            Camera::ThinLens(t) => t.differential_rays(film_pos, aperture_u),
        };
        let (dx, dy) = (dx.normalize(), dy.normalize());
        let differential = (dx.is_finite() && dy.is_finite()).then_some(RayDifferential {
            rx_o: origin,
            rx_d: dx,
            ry_o: origin,
            ry_d: dy,
        });
        CameraRay { ray, differential }
    }

    /// The camera position (the lens centre) in world space.
    pub fn position(&self) -> Vec3 {
        self.projection().position()
    }

    /// Camera-to-world transform (rigid).
    pub fn to_world(&self) -> Mat4 {
        self.projection().to_world()
    }

    /// Full film size in pixels the camera was built for.
    pub fn film_size(&self) -> Vec2 {
        self.projection().film_size()
    }

    /// Projects a world point through the lens centre to film coordinates (pixels, same convention as
    /// [`Camera::generate_ray`]). `None` if the point is not in front of the camera; points outside the
    /// image are still returned (with coordinates outside [0, width] × [0, height]) so that callers can
    /// clip lines themselves.
    pub fn world_to_film(&self, p: Vec3) -> Option<Vec2> {
        let proj = self.projection();
        proj.local_to_film(proj.to_local().transform_point3(p))
    }
}
