//! Ray–scene intersection back-ends. A coarse extension point: the default is a compressed wide BVH from
//! `obvhs`; an Embree back-end can be added behind a cargo feature.

mod bvh;

pub use bvh::BvhAccel;

use crate::ray::Ray;
use glam::Vec2;

/// The closest hit of a ray, before surface data is computed.
#[derive(Clone, Copy, Debug)]
pub struct PrimHit {
    /// Ray parameter.
    pub t: f32,
    /// Index of the shape in the scene.
    pub shape: u32,
    /// Triangle index within a mesh (0 for analytic shapes).
    pub prim: u32,
    /// Barycentrics (b1, b2) for triangles.
    pub bary: Vec2,
}

/// A ray-intersection structure over the scene's shapes.
pub trait Accel: Send + Sync {
    /// Closest hit with `0 < t < ray.t_max`.
    fn intersect(&self, ray: &Ray) -> Option<PrimHit>;
    /// True if anything is hit with `0 < t < ray.t_max`.
    fn occluded(&self, ray: &Ray) -> bool;
}
