//! Wavefront OBJ loading (via `tobj`): polygons fanned into triangles, all objects and groups merged.

use super::MeshData;
use crate::error::{SceneError, SceneResult, SourceLoc};
use glam::{Vec2, Vec3};
use std::path::Path;

/// Loads an OBJ file as one triangle mesh. `loc` is where the scene names the file (errors about the
/// file as a whole point there). `flip_tex_coords` maps v to 1 − v (Mitsuba's default is true).
/// Normals are kept only if every vertex has a usable one; otherwise the caller computes them.
pub fn load_obj(path: &Path, loc: &SourceLoc, flip_tex_coords: bool) -> SceneResult<MeshData> {
    if !path.is_file() {
        return Err(SceneError::at(
            loc,
            format!("OBJ file '{}' not found", path.display()),
        ));
    }
    // One index buffer, polygons fanned into triangles, points and lines ignored. Materials are
    // Mitsuba's business (BSDFs in the XML), so a missing .mtl is not an error.
    let (models, _materials) = tobj::load_obj(path, &tobj::GPU_LOAD_OPTIONS).map_err(|e| {
        SceneError::at(
            loc,
            format!("cannot load OBJ file '{}': {e}", path.display()),
        )
    })?;

    let all_have_normals = models
        .iter()
        .all(|m| !m.mesh.normals.is_empty() && m.mesh.normals.len() == m.mesh.positions.len());
    let any_has_uvs = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    let mut mesh = MeshData {
        normals: all_have_normals.then(Vec::new),
        uvs: any_has_uvs.then(Vec::new),
        ..Default::default()
    };
    for model in &models {
        let m = &model.mesh;
        let base = u32::try_from(mesh.positions.len()).map_err(|_| too_large(path, loc))?;
        let count = m.positions.len() / 3;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if let Some(normals) = &mut mesh.normals {
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        }
        if let Some(uvs) = &mut mesh.uvs {
            if m.texcoords.len() == 2 * count {
                uvs.extend(
                    m.texcoords
                        .chunks_exact(2)
                        .map(|t| Vec2::new(t[0], if flip_tex_coords { 1.0 - t[1] } else { t[1] })),
                );
            } else {
                // Objects without (or with partial) uvs in a file where others have them.
                uvs.extend(std::iter::repeat_n(Vec2::ZERO, count));
            }
        }
        for t in m.indices.chunks_exact(3) {
            let tri = [t[0], t[1], t[2]].map(|i| base.checked_add(i));
            let [Some(a), Some(b), Some(c)] = tri else {
                return Err(too_large(path, loc));
            };
            mesh.indices.push([a, b, c]);
        }
    }
    finish(mesh, path, loc, "OBJ")
}

fn too_large(path: &Path, loc: &SourceLoc) -> SceneError {
    SceneError::at(
        loc,
        format!("mesh file '{}' has more than 2^32 vertices", path.display()),
    )
}

/// Validates a freshly loaded mesh, drops unusable normals and zero-area triangles.
pub(super) fn finish(
    mut mesh: MeshData,
    path: &Path,
    loc: &SourceLoc,
    format: &str,
) -> SceneResult<MeshData> {
    mesh.validate(path)?;
    if let Some(normals) = &mut mesh.normals {
        // A zero normal cannot shade; then the smooth normals are computed instead, as for no normals.
        let ok = normals.iter_mut().all(|n| match n.try_normalize() {
            Some(u) => {
                *n = u;
                true
            }
            None => false,
        });
        if !ok {
            mesh.normals = None;
        }
    }
    mesh.drop_degenerate_triangles();
    if mesh.indices.is_empty() {
        return Err(SceneError::at(
            loc,
            format!(
                "{format} file '{}' contains no triangles of non-zero area",
                path.display()
            ),
        ));
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::test_data_dir;
    use std::path::PathBuf;

    fn loc() -> SourceLoc {
        SourceLoc {
            file: std::sync::Arc::new(PathBuf::from("scene.xml")),
            line: 7,
            col: 3,
        }
    }

    fn temp_file(name: &str, contents: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("focal-obj-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, contents).unwrap();
        path
    }

    #[test]
    fn reference_meshes_load_with_the_right_counts() {
        let dir = test_data_dir().join("references/scenes");
        let f = load_obj(&dir.join("letter_f.obj"), &loc(), true).unwrap();
        assert_eq!(f.indices.len(), 36);
        assert_eq!(f.positions.len(), 72);
        assert!(f.normals.is_none() && f.uvs.is_none());
        let wall = load_obj(&dir.join("wall_hole.obj"), &loc(), true).unwrap();
        assert_eq!(wall.indices.len(), 8);
        assert_eq!(wall.positions.len(), 8);
        // The wall faces -Z (into the room), as its comment says.
        for t in &wall.indices {
            let [a, b, c] = t.map(|i| wall.positions[i as usize]);
            assert!((b - a).cross(c - a).normalize().dot(Vec3::NEG_Z) > 0.999);
        }
    }

    #[test]
    fn polygons_are_fanned_uvs_flipped_and_normals_kept() {
        let path = temp_file(
            "pentagon.obj",
            "v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 2 0\nv -0.5 1 0\n\
             vt 0 0.25\nvn 0 0 2\n\
             f 1/1/1 2/1/1 3/1/1 4/1/1 5/1/1\n",
        );
        let m = load_obj(&path, &loc(), true).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert_eq!(m.uvs.as_ref().unwrap()[0], Vec2::new(0.0, 0.75));
        assert_eq!(m.normals.as_ref().unwrap()[0], Vec3::Z);
        let m = load_obj(&path, &loc(), false).unwrap();
        assert_eq!(m.uvs.as_ref().unwrap()[0], Vec2::new(0.0, 0.25));
    }

    #[test]
    fn groups_are_merged_into_one_mesh() {
        let path = temp_file(
            "two_groups.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\no a\nf 1 2 3\no b\nf 1 2 4\n",
        );
        let m = load_obj(&path, &loc(), true).unwrap();
        assert_eq!(m.indices.len(), 2);
        m.validate(&path).unwrap();
    }

    #[test]
    fn broken_files_give_errors_naming_the_file() {
        let missing = Path::new("/nonexistent/dir/missing_mesh.obj");
        let e = load_obj(missing, &loc(), true).unwrap_err();
        assert!(e.to_string().contains("missing_mesh.obj"), "{e}");
        assert!(e.to_string().starts_with("scene.xml:7:3"), "{e}");

        let cases = [
            ("malformed.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n"),
            ("out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
            ("nan_vertex.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
            ("no_faces.obj", "v 0 0 0\nv 1 0 0\n"),
        ];
        for (name, text) in cases {
            let path = temp_file(name, text);
            let e = load_obj(&path, &loc(), true).unwrap_err();
            assert!(e.to_string().contains(name), "{name}: {e}");
        }
    }
}
