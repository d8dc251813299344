//! The in-memory triangle mesh shared by the file loaders and the builder.

use crate::error::{SceneError, SceneResult};
use glam::{DMat3, DVec3, Mat4, Vec2, Vec3};
use std::path::Path;

/// An indexed triangle mesh: per-vertex positions and optional normals and uv coordinates.
/// Counter-clockwise triangles (seen from the front) face the side their geometric normal points to.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit shading normals, one per vertex, if the file had them.
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates, one per vertex, if the file had them.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles as indices into the vertex arrays.
    pub indices: Vec<[u32; 3]>,
}

impl MeshData {
    /// Smooth vertex normals: each vertex averages the normals of its triangles weighted by the angle
    /// the triangle makes at that vertex (Thürmer and Wüthrich 1998, as Mitsuba). Zero-area triangles
    /// and triangles with invalid indices contribute nothing; a vertex with no valid triangle gets
    /// (1, 0, 0), as in Mitsuba.
    pub fn compute_vertex_normals(&self) -> Vec<Vec3> {
        let mut acc = vec![DVec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let Some(p) = self.corners(tri) else { continue };
            let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
                continue;
            };
            for k in 0..3 {
                let d0 = (p[(k + 1) % 3] - p[k]).try_normalize();
                let d1 = (p[(k + 2) % 3] - p[k]).try_normalize();
                if let (Some(d0), Some(d1)) = (d0, d1) {
                    let angle = d0.dot(d1).clamp(-1.0, 1.0).acos();
                    acc[tri[k] as usize] += n * angle;
                }
            }
        }
        acc.into_iter()
            .map(|n| n.try_normalize().map_or(Vec3::X, |n| n.as_vec3()))
            .collect()
    }

    /// Moves the mesh by `m`: positions as points, normals with the inverse transpose (renormalised).
    /// Indices are kept as they are even when `m` mirrors (as Mitsuba does), so a mirrored mesh's
    /// geometric normals flip while its shading normals follow the surface.
    pub fn transform(&mut self, m: &Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        if let Some(normals) = &mut self.normals {
            let normal_matrix = normal_matrix(m);
            for n in normals.iter_mut() {
                let t = normal_matrix * n.as_dvec3();
                *n = t.try_normalize().map_or(Vec3::X, |t| t.as_vec3());
            }
        }
    }

    /// Checks what a broken file could get wrong: every index in range, positions, normals and uvs
    /// finite, one normal and uv per vertex. The error names `file` and the offending vertex or face.
    pub fn validate(&self, file: &Path) -> SceneResult<()> {
        let n = self.positions.len();
        let fail = |msg: String| Err(SceneError::in_file(file, msg));
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return fail(format!(
                "vertex {i} has a non-finite position {}",
                self.positions[i]
            ));
        }
        if let Some(normals) = &self.normals {
            if normals.len() != n {
                return fail(format!("{} normals for {n} vertices", normals.len()));
            }
            if let Some(i) = normals.iter().position(|v| !v.is_finite()) {
                return fail(format!("vertex {i} has a non-finite normal {}", normals[i]));
            }
        }
        if let Some(uvs) = &self.uvs {
            if uvs.len() != n {
                return fail(format!(
                    "{} texture coordinates for {n} vertices",
                    uvs.len()
                ));
            }
            if let Some(i) = uvs.iter().position(|v| !v.is_finite()) {
                return fail(format!(
                    "vertex {i} has non-finite texture coordinates {}",
                    uvs[i]
                ));
            }
        }
        for (f, tri) in self.indices.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
                return fail(format!(
                    "face {f} references vertex {i}, but the mesh has only {n} vertices"
                ));
            }
        }
        Ok(())
    }

    /// Removes triangles of zero area (they can never be hit or sampled); returns how many.
    /// Call after [`MeshData::validate`].
    pub fn drop_degenerate_triangles(&mut self) -> usize {
        let before = self.indices.len();
        let positions = &self.positions;
        self.indices.retain(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            (b - a).cross(c - a).length_squared() > 0.0
        });
        before - self.indices.len()
    }

    fn corners(&self, tri: &[u32; 3]) -> Option<[DVec3; 3]> {
        let p = |i: u32| self.positions.get(i as usize).map(|p| p.as_dvec3());
        Some([p(tri[0])?, p(tri[1])?, p(tri[2])?])
    }
}

/// The matrix that maps normals under `m`: the inverse transpose of its linear part, computed as the
/// cofactor matrix times sign(det) so that it stays defined (if degenerate) for singular matrices.
fn normal_matrix(m: &Mat4) -> DMat3 {
    let a = DMat3::from_mat4(m.as_dmat4());
    let (c0, c1, c2) = (a.x_axis, a.y_axis, a.z_axis);
    let cofactor = DMat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
    cofactor * a.determinant().signum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cube [-1,1]³ with 8 shared vertices and counter-clockwise (outward) triangles.
    fn cube() -> MeshData {
        let positions = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 != 0 { 1.0 } else { -1.0 },
                    if i & 2 != 0 { 1.0 } else { -1.0 },
                    if i & 4 != 0 { 1.0 } else { -1.0 },
                )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1], // z = -1
            [4, 5, 7, 6], // z = +1
            [0, 1, 5, 4], // y = -1
            [2, 6, 7, 3], // y = +1
            [0, 4, 6, 2], // x = -1
            [1, 3, 7, 5], // x = +1
        ];
        let indices = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        MeshData {
            positions,
            normals: None,
            uvs: None,
            indices,
        }
    }

    #[test]
    fn cube_faces_point_outwards() {
        let m = cube();
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0) > 0.0, "face {t:?} points inwards");
        }
    }

    #[test]
    fn closed_cube_vertex_normals_are_outward_diagonals() {
        let m = cube();
        let normals = m.compute_vertex_normals();
        for (p, n) in m.positions.iter().zip(&normals) {
            // Angle weighting gives each of the three faces at a corner 90°, however the quads were
            // split, so the normal is exactly the diagonal; area or count weighting would tilt it.
            let expected = p.normalize();
            assert!(
                (*n - expected).length() < 1e-6,
                "normal {n} at {p}, expected {expected}"
            );
        }
    }

    #[test]
    fn transform_moves_points_and_maps_normals_with_inverse_transpose() {
        let mut m = MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some(vec![Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::X, Vec3::Z]),
            uvs: None,
            indices: vec![[0, 1, 2]],
        };
        let t = Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0))
            * Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
        m.transform(&t);
        assert_eq!(
            m.positions,
            vec![
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(2.0, 0.0, 5.0),
                Vec3::new(0.0, 1.0, 5.0)
            ]
        );
        let n = m.normals.as_ref().unwrap();
        // The surface x + y = c becomes x/2 + y = c: normal (0.5, 1, 0).
        assert!((n[0] - Vec3::new(0.5, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!((n[1] - Vec3::X).length() < 1e-6);
        assert_eq!(m.indices, vec![[0, 1, 2]]);

        // A mirror keeps the winding and mirrors the normals.
        m.transform(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        assert!((m.normals.as_ref().unwrap()[1] + Vec3::X).length() < 1e-6);
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn validate_reports_bad_indices_and_values() {
        let file = Path::new("broken_mesh.obj");
        let mut m = cube();
        assert!(m.validate(file).is_ok());
        m.indices.push([0, 1, 8]);
        let e = m.validate(file).unwrap_err().to_string();
        assert!(
            e.contains("broken_mesh.obj") && e.contains("face 12") && e.contains("vertex 8"),
            "{e}"
        );
        m.indices.pop();
        m.positions[3].y = f32::NAN;
        let e = m.validate(file).unwrap_err().to_string();
        assert!(
            e.contains("broken_mesh.obj") && e.contains("vertex 3"),
            "{e}"
        );
        m.positions[3].y = 1.0;
        m.uvs = Some(vec![Vec2::ZERO; 7]);
        assert!(m.validate(file).is_err());
    }

    #[test]
    fn degenerate_triangles_are_dropped() {
        let mut m = cube();
        m.indices.push([0, 0, 1]);
        m.indices.push([0, 1, 1]);
        assert_eq!(m.drop_degenerate_triangles(), 2);
        assert_eq!(m.indices.len(), 12);
    }
}
