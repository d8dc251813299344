//! Rays with a parametric extent.

use glam::Vec3;

/// A ray `o + t d` for `t` in `(0, t_max)`; `d` is unit length unless stated otherwise.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin (already offset from the surface it leaves, see [`offset_ray_origin`]).
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// Largest parameter considered (exclusive).
    pub t_max: f32,
}

impl Ray {
    /// A ray of unbounded extent.
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            t_max: f32::INFINITY,
        }
    }

    /// A ray limited to `t < t_max`.
    #[inline]
    pub fn segment(o: Vec3, d: Vec3, t_max: f32) -> Self {
        Ray { o, d, t_max }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Moves a surface point off its surface along the geometric normal, to the side of `dir`, far enough that
/// the new ray cannot re-hit the surface it starts on. The offset scales with the magnitude of the point's
/// coordinates because float spacing does (the approach of Wächter & Binder, Ray Tracing Gems ch. 6).
#[inline]
pub fn offset_ray_origin(p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if ng.dot(dir) < 0.0 { -ng } else { ng };
    let of_i = [
        (INT_SCALE * n.x) as i32,
        (INT_SCALE * n.y) as i32,
        (INT_SCALE * n.z) as i32,
    ];
    let p_i = |c: f32, o: i32| -> f32 {
        let bits = c.to_bits() as i32;
        f32::from_bits((bits + if c < 0.0 { -o } else { o }) as u32)
    };
    let pi = Vec3::new(p_i(p.x, of_i[0]), p_i(p.y, of_i[1]), p_i(p.z, of_i[2]));
    Vec3::new(
        if p.x.abs() < ORIGIN {
            p.x + FLOAT_SCALE * n.x
        } else {
            pi.x
        },
        if p.y.abs() < ORIGIN {
            p.y + FLOAT_SCALE * n.y
        } else {
            pi.y
        },
        if p.z.abs() < ORIGIN {
            p.z + FLOAT_SCALE * n.z
        } else {
            pi.z
        },
    )
}

/// The rays through the neighbouring film positions one pixel step to the right (`x`) and down (`y`) of
/// a camera ray, already scaled to the render's sample density (Mitsuba 0.6's ray differentials,
/// `scaleDifferential(1/√spp)`). They give the footprint of a pixel sample on the first surface hit,
/// which MIP-mapped textures filter over.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDifferential {
    /// Origin of the ray one step along x.
    pub rx_o: Vec3,
    /// Direction of the ray one step along x (not necessarily unit length).
    pub rx_d: Vec3,
    /// Origin of the ray one step along y.
    pub ry_o: Vec3,
    /// Direction of the ray one step along y.
    pub ry_d: Vec3,
}

impl RayDifferential {
    /// Moves the offset rays towards the main ray by `amount` (Mitsuba's `scaleDifferential`).
    pub fn scaled(&self, ray: &Ray, amount: f32) -> Self {
        RayDifferential {
            rx_o: ray.o + (self.rx_o - ray.o) * amount,
            rx_d: ray.d + (self.rx_d - ray.d) * amount,
            ry_o: ray.o + (self.ry_o - ray.o) * amount,
            ry_d: ray.d + (self.ry_d - ray.d) * amount,
        }
    }
}

/// A primary ray with the differentials of its pixel footprint, if the camera provides them.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    /// The ray.
    pub ray: Ray,
    /// Offset rays for texture filtering at the first hit.
    pub differential: Option<RayDifferential>,
}

impl From<Ray> for CameraRay {
    fn from(ray: Ray) -> Self {
        CameraRay {
            ray,
            differential: None,
        }
    }
}
