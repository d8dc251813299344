//! World-space triangle meshes with area sampling.

use super::{Aabb, PositionSample};
use crate::warp::square_to_uniform_triangle;
use glam::{Vec2, Vec3};

/// A triangle mesh in world space.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (unit), if the mesh is smooth-shaded.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex uv coordinates.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles (counter-clockwise seen from the front: face normal = (v1 − v0) × (v2 − v0)).
    pub indices: Vec<[u32; 3]>,
    /// Whether normals are flipped (`flip_normals`).
    pub flip_normals: bool,
    /// Cumulative triangle areas (for uniform area sampling); last entry = total area.
    area_cdf: Vec<f32>,
}

impl TriangleMesh {
    /// Builds a mesh, dropping triangles of zero area (they can never be hit or sampled).
    pub fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
        flip_normals: bool,
    ) -> Self {
        let indices: Vec<[u32; 3]> = indices
            .into_iter()
            .filter(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                (b - a).cross(c - a).length_squared() > 0.0
            })
            .collect();
        let mut mesh = TriangleMesh {
            positions,
            normals,
            uvs,
            indices,
            flip_normals,
            area_cdf: Vec::new(),
        };
        let mut acc = 0.0f64;
        mesh.area_cdf = (0..mesh.indices.len())
            .map(|i| {
                acc += mesh.triangle_area(i) as f64;
                acc as f32
            })
            .collect();
        mesh
    }

    /// The three corners of triangle `i`.
    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: usize) -> f32 {
        let [a, b, c] = self.vertices(i);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        self.area_cdf.last().copied().unwrap_or(0.0)
    }

    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for t in &self.indices {
            for &k in t {
                b.expand(self.positions[k as usize]);
            }
        }
        b
    }

    /// Geometric normal of triangle `i` (respecting `flip_normals`).
    #[inline]
    pub fn face_normal(&self, i: usize) -> Vec3 {
        let [a, b, c] = self.vertices(i);
        let n = (b - a).cross(c - a).normalize();
        if self.flip_normals {
            -n
        } else {
            n
        }
    }

    /// Shading normal at barycentrics (b1, b2) of triangle `i`, oriented to agree with the face normal's
    /// flip state (Mitsuba flips both).
    #[inline]
    pub fn shading_normal(&self, i: usize, b: Vec2) -> Vec3 {
        match &self.normals {
            Some(ns) => {
                let [i0, i1, i2] = self.indices[i];
                let n = ns[i0 as usize] * (1.0 - b.x - b.y)
                    + ns[i1 as usize] * b.x
                    + ns[i2 as usize] * b.y;
                let n = n.normalize_or_zero();
                if n == Vec3::ZERO {
                    return self.face_normal(i);
                }
                if self.flip_normals {
                    -n
                } else {
                    n
                }
            }
            None => self.face_normal(i),
        }
    }

    /// uv at barycentrics of triangle `i` (Mitsuba's default without uvs: the barycentrics themselves).
    #[inline]
    pub fn uv(&self, i: usize, b: Vec2) -> Vec2 {
        match &self.uvs {
            Some(uvs) => {
                let [i0, i1, i2] = self.indices[i];
                uvs[i0 as usize] * (1.0 - b.x - b.y)
                    + uvs[i1 as usize] * b.x
                    + uvs[i2 as usize] * b.y
            }
            None => b,
        }
    }

    /// Samples a point uniformly by area; `u1` picks the triangle.
    pub fn sample_position(&self, u1: f32, u2: Vec2) -> PositionSample {
        let total = self.area();
        let target = u1 * total;
        let i = self
            .area_cdf
            .partition_point(|&c| c <= target)
            .min(self.indices.len() - 1);
        let b = square_to_uniform_triangle(u2);
        let [a, bb, c] = self.vertices(i);
        let p = a * (1.0 - b.x - b.y) + bb * b.x + c * b.y;
        PositionSample {
            p,
            n: self.shading_normal(i, b),
            pdf_area: 1.0 / total,
        }
    }
}
