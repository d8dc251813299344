//! Geometry: triangle meshes and analytic quadrics, their intersection, sampling and surface data.

mod aabb;
mod canonical;
mod cylinder;
mod disk;
mod interaction;
mod shape_geometry;
mod sphere;
mod triangle_mesh;

pub use aabb::Aabb;
pub use canonical::{cube_mesh, rectangle_mesh};
pub use cylinder::Cylinder;
pub use disk::Disk;
pub use interaction::SurfaceInteraction;
pub use shape_geometry::ShapeGeometry;
pub use sphere::Sphere;
pub use triangle_mesh::TriangleMesh;

use glam::Vec3;

/// A point sampled on a surface, with the density of having sampled it.
#[derive(Clone, Copy, Debug)]
pub struct PositionSample {
    /// The point.
    pub p: Vec3,
    /// The (outward, i.e. shading-side) surface normal at the point.
    pub n: Vec3,
    /// Density per unit area.
    pub pdf_area: f32,
}
