//! Surface hit records.

use crate::frame::Frame;
use glam::{Vec2, Vec3};

/// Everything the integrator needs to know about a ray–surface hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Hit position.
    pub p: Vec3,
    /// Geometric normal (unit; on the side given by the shape's orientation, flipped by `flip_normals`).
    pub ng: Vec3,
    /// Shading frame (interpolated normal, flipped consistently with `ng`).
    pub sh_frame: Frame,
    /// Surface uv coordinates.
    pub uv: Vec2,
    /// ∂p/∂u of the surface's uv parameterisation (world space, not normalised), for bump maps.
    pub dp_du: Vec3,
    /// ∂p/∂v (world space, not normalised).
    pub dp_dv: Vec3,
    /// Index of the shape (scene-level) that was hit.
    pub shape: u32,
    /// Triangle index within a mesh (0 for analytic shapes).
    pub prim: u32,
}

impl SurfaceInteraction {
    /// World → shading frame.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_local(v)
    }

    /// Shading frame → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_world(v)
    }
}
