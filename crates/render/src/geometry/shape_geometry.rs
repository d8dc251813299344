//! The closed set of shape geometries.

use super::{Aabb, Cylinder, Disk, PositionSample, Sphere, TriangleMesh};
use glam::Vec2;

/// The geometry of one scene shape.
#[derive(Clone, Debug)]
pub enum ShapeGeometry {
    /// A triangle mesh (obj, ply, serialized, rectangle, cube, ...).
    Mesh(TriangleMesh),
    /// An analytic sphere.
    Sphere(Sphere),
    /// An analytic disk.
    Disk(Disk),
    /// An analytic open cylinder.
    Cylinder(Cylinder),
}

impl ShapeGeometry {
    /// Surface area.
    pub fn area(&self) -> f32 {
        match self {
            ShapeGeometry::Mesh(m) => m.area(),
            ShapeGeometry::Sphere(s) => s.area(),
            ShapeGeometry::Disk(d) => d.area(),
            ShapeGeometry::Cylinder(c) => c.area(),
        }
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        match self {
            ShapeGeometry::Mesh(m) => m.bounds(),
            ShapeGeometry::Sphere(s) => s.bounds(),
            ShapeGeometry::Disk(d) => d.bounds(),
            ShapeGeometry::Cylinder(c) => c.bounds(),
        }
    }

    /// Uniform area sampling; `u1` is used by meshes to choose the triangle.
    pub fn sample_position(&self, u1: f32, u2: Vec2) -> PositionSample {
        match self {
            ShapeGeometry::Mesh(m) => m.sample_position(u1, u2),
            ShapeGeometry::Sphere(s) => s.sample_position(u2),
            ShapeGeometry::Disk(d) => d.sample_position(u2),
            ShapeGeometry::Cylinder(c) => c.sample_position(u2),
        }
    }

    /// Number of BVH primitives this shape contributes.
    pub fn primitive_count(&self) -> usize {
        match self {
            ShapeGeometry::Mesh(m) => m.indices.len(),
            _ => 1,
        }
    }
}
