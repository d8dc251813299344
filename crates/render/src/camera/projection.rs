//! The pinhole projection shared by the perspective and thin-lens cameras: the camera frame and the
//! mapping between film positions and camera-space directions (Mitsuba 3's `perspective_projection`).

use crate::desc::ObjectDesc;
use crate::error::SceneResult;
use glam::{Mat3, Mat4, UVec2, Vec2, Vec3, Vec4};

/// Largest deviation of the camera rotation's Gram matrix from the identity that still counts as "no
/// scale" (Mitsuba 3's `Transform::has_scale` threshold).
const SCALE_TOLERANCE: f32 = 1e-3;

/// Camera frame and field of view. Camera space looks along +Z with +Y up and +X to the image's left
/// (Mitsuba's `lookat` frame); film positions are in pixels of the full film, (0, 0) = top-left corner.
#[derive(Clone, Debug)]
pub struct Projection {
    to_world: Mat4,
    to_local: Mat4,
    film_size: Vec2,
    /// tan(x_fov / 2): half-width of the image on the z = 1 plane.
    tan_half_x: f32,
    /// width / height of the full film.
    aspect: f32,
    x_fov_deg: f64,
    near_clip: f32,
    far_clip: f32,
}

impl Projection {
    /// A projection for a rigid `to_world` (see [`rigid_camera_to_world`]), a film of `film_size` pixels,
    /// a horizontal field of view in degrees and the clip distances.
    pub fn new(
        to_world: Mat4,
        film_size: UVec2,
        x_fov_deg: f64,
        near_clip: f32,
        far_clip: f32,
    ) -> Self {
        let film_size = film_size.max(UVec2::ONE).as_vec2();
        Projection {
            to_world,
            to_local: to_world.inverse(),
            film_size,
            tan_half_x: (0.5 * x_fov_deg.to_radians()).tan() as f32,
            aspect: film_size.x / film_size.y,
            x_fov_deg,
            near_clip,
            far_clip,
        }
    }

    /// Camera-to-world transform (rigid: rotation or reflection plus translation).
    pub fn to_world(&self) -> Mat4 {
        self.to_world
    }

    /// World-to-camera transform.
    pub fn to_local(&self) -> Mat4 {
        self.to_local
    }

    /// Full film size in pixels.
    pub fn film_size(&self) -> Vec2 {
        self.film_size
    }

    /// Horizontal field of view in degrees.
    pub fn x_fov_degrees(&self) -> f64 {
        self.x_fov_deg
    }

    /// Distance of the near clip plane along the viewing axis.
    pub fn near_clip(&self) -> f32 {
        self.near_clip
    }

    /// Distance of the far clip plane along the viewing axis.
    pub fn far_clip(&self) -> f32 {
        self.far_clip
    }

    /// Camera position in world space.
    pub fn position(&self) -> Vec3 {
        self.to_world.w_axis.truncate()
    }

    /// The camera-space point on the z = 1 plane seen through film position `film_pos` (pixels).
    #[inline]
    pub fn film_to_local_plane(&self, film_pos: Vec2) -> Vec3 {
        let s = film_pos / self.film_size;
        // Sample x = 0 is the image's left edge, which is camera +X; row 0 is the top, camera +Y.
        Vec3::new(
            (1.0 - 2.0 * s.x) * self.tan_half_x,
            (1.0 - 2.0 * s.y) * self.tan_half_x / self.aspect,
            1.0,
        )
    }

    /// The film position (pixels) of a camera-space point, or `None` if it is not in front of the camera.
    #[inline]
    pub fn local_to_film(&self, p: Vec3) -> Option<Vec2> {
        // Also rejects NaN depths.
        if p.z.is_nan() || p.z <= 0.0 {
            return None;
        }
        let x = p.x / (p.z * self.tan_half_x);
        let y = p.y * self.aspect / (p.z * self.tan_half_x);
        let s = Vec2::new(0.5 * (1.0 - x), 0.5 * (1.0 - y));
        let f = s * self.film_size;
        f.is_finite().then_some(f)
    }

    /// Transforms a camera-space direction to world space.
    #[inline]
    pub fn dir_to_world(&self, d: Vec3) -> Vec3 {
        self.to_world.transform_vector3(d)
    }
}

/// Reads the sensor's `to_world` and checks that it is rigid, as Mitsuba 3 requires ("Scale factors in
/// the camera-to-world transformation are not allowed"). Reflections are allowed (they mirror the image,
/// as in Mitsuba). Within the tolerance, the rotation part is re-orthonormalised so that camera rays
/// are exactly unit length; a real scale, shear or projective row is a [`crate::error::SceneError`].
pub fn rigid_camera_to_world(sensor: &ObjectDesc) -> SceneResult<Mat4> {
    let m = sensor.transform_or_identity("to_world")?;
    if !m.is_finite() {
        return Err(sensor.error("the camera's to_world transform contains non-finite values"));
    }
    if (m.row(3) - Vec4::W).abs().max_element() > 1e-6 {
        return Err(
            sensor.error("the camera's to_world transform must be affine (last row 0 0 0 1)")
        );
    }
    let r = Mat3::from_mat4(m);
    let gram = r.transpose() * r;
    let dev = [
        gram.x_axis - Vec3::X,
        gram.y_axis - Vec3::Y,
        gram.z_axis - Vec3::Z,
    ]
    .iter()
    .map(|c| c.abs().max_element())
    .fold(0.0f32, f32::max);
    if dev > SCALE_TOLERANCE {
        return Err(sensor.error(
            "scale factors in the camera's to_world transform are not allowed (it must be a rotation, \
             possibly with a reflection, plus a translation)",
        ));
    }
    // Gram-Schmidt keeping the viewing axis (+Z) exact, then the handedness of the original.
    let z = r.z_axis.normalize();
    let x = (r.x_axis - z * z.dot(r.x_axis)).normalize();
    let y = z.cross(x) * r.determinant().signum();
    Ok(Mat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        z.extend(0.0),
        m.w_axis,
    ))
}
