//! Stanford PLY loading (via `ply-rs-bw`, ASCII and binary): vertex positions with optional normals and
//! texture coordinates, polygon faces fanned into triangles.

use super::obj::finish;
use super::MeshData;
use crate::error::{SceneError, SceneResult, SourceLoc};
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use std::path::Path;

/// Names under which PLY writers store texture coordinates.
const UV_NAMES: [(&str, &str); 4] = [
    ("u", "v"),
    ("s", "t"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

/// Loads a PLY file as one triangle mesh. `loc` is where the scene names the file.
pub fn load_ply(path: &Path, loc: &SourceLoc) -> SceneResult<MeshData> {
    let file = std::fs::File::open(path).map_err(|e| {
        SceneError::at(
            loc,
            format!("cannot open PLY file '{}': {e}", path.display()),
        )
    })?;
    let mut reader = std::io::BufReader::new(file);
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut reader)
        .map_err(|e| {
            SceneError::at(
                loc,
                format!("cannot read PLY file '{}': {e}", path.display()),
            )
        })?;
    let fail = |msg: String| SceneError::at(loc, format!("PLY file '{}': {msg}", path.display()));

    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| fail("no 'vertex' element".into()))?;
    let faces = ply
        .payload
        .get("face")
        .ok_or_else(|| fail("no 'face' element".into()))?;

    let mut mesh = MeshData::default();
    for (i, v) in vertices.iter().enumerate() {
        let [Some(x), Some(y), Some(z)] = ["x", "y", "z"].map(|k| scalar(v, k)) else {
            return Err(fail(format!("vertex {i} lacks an x, y or z coordinate")));
        };
        mesh.positions.push(Vec3::new(x as f32, y as f32, z as f32));
    }
    let normals: Option<Vec<Vec3>> = vertices
        .iter()
        .map(|v| {
            let [x, y, z] = ["nx", "ny", "nz"].map(|k| scalar(v, k));
            Some(Vec3::new(x? as f32, y? as f32, z? as f32))
        })
        .collect();
    mesh.normals = normals.filter(|n| !n.is_empty());
    mesh.uvs = UV_NAMES.iter().find_map(|(u, v)| {
        let uvs: Option<Vec<Vec2>> = vertices
            .iter()
            .map(|e| Some(Vec2::new(scalar(e, u)? as f32, scalar(e, v)? as f32)))
            .collect();
        uvs.filter(|t| !t.is_empty())
    });

    for (f, face) in faces.iter().enumerate() {
        let list = ["vertex_indices", "vertex_index"]
            .iter()
            .find_map(|k| index_list(face, k))
            .ok_or_else(|| fail(format!("face {f} has no 'vertex_indices' list")))?;
        let idx: Vec<u32> = list
            .iter()
            .map(|&i| u32::try_from(i))
            .collect::<Result<_, _>>()
            .map_err(|_| fail(format!("face {f} has a negative or too large vertex index")))?;
        for k in 1..idx.len().saturating_sub(1) {
            mesh.indices.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    finish(mesh, path, loc, "PLY")
}

/// A numeric scalar property as f64.
fn scalar(e: &DefaultElement, key: &str) -> Option<f64> {
    Some(match e.get(key)? {
        Property::Char(v) => *v as f64,
        Property::UChar(v) => *v as f64,
        Property::Short(v) => *v as f64,
        Property::UShort(v) => *v as f64,
        Property::Int(v) => *v as f64,
        Property::UInt(v) => *v as f64,
        Property::Float(v) => *v as f64,
        Property::Double(v) => *v,
        _ => return None,
    })
}

/// An integer list property (any integer type) as i64.
fn index_list(e: &DefaultElement, key: &str) -> Option<Vec<i64>> {
    Some(match e.get(key)? {
        Property::ListChar(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUChar(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListShort(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUShort(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListInt(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUInt(v) => v.iter().map(|&i| i as i64).collect(),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::test_data_dir;
    use std::path::PathBuf;

    fn loc() -> SourceLoc {
        SourceLoc {
            file: std::sync::Arc::new(PathBuf::from("scene.xml")),
            line: 12,
            col: 5,
        }
    }

    fn temp_file(name: &str, contents: &[u8]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("focal-ply-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, contents).unwrap();
        path
    }

    const ASCII_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
        property float s\nproperty float t\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n";

    #[test]
    fn binary_reference_pyramid_loads() {
        let m = load_ply(
            &test_data_dir().join("references/scenes/pyramid.ply"),
            &loc(),
        )
        .unwrap();
        assert_eq!(m.positions.len(), 16);
        assert_eq!(m.indices.len(), 6);
        assert!(m.normals.is_none() && m.uvs.is_none());
        // A closed pyramid: every face points away from the interior point above the base centre.
        let inside = m.positions.iter().copied().sum::<Vec3>() / 16.0;
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!(
                (b - a).cross(c - a).dot(a - inside) > 0.0,
                "face {t:?} points inwards"
            );
        }
    }

    #[test]
    fn ascii_quad_with_normals_and_uvs() {
        let text = format!(
            "{ASCII_HEADER}0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n"
        );
        let m = load_ply(&temp_file("quad.ply", text.as_bytes()), &loc()).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.normals.as_ref().unwrap()[2], Vec3::Z);
        assert_eq!(m.uvs.as_ref().unwrap()[2], Vec2::new(1.0, 1.0));
    }

    #[test]
    fn broken_files_give_errors_naming_the_file() {
        let e = load_ply(Path::new("/nonexistent/missing_mesh.ply"), &loc()).unwrap_err();
        assert!(e.to_string().contains("missing_mesh.ply"), "{e}");

        let v = "0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n";
        let cases = [
            (
                "malformed.ply",
                "ply\nformat ascii 1.0\nelement vertex oops\nend_header\n".to_string(),
            ),
            ("truncated.ply", format!("{ASCII_HEADER}0 0 0 0 0 1 0 0\n")),
            (
                "out_of_range.ply",
                format!("{ASCII_HEADER}{v}0 1 0 0 0 1 0 1\n3 0 1 7\n"),
            ),
            (
                "nan_vertex.ply",
                format!("{ASCII_HEADER}{v}nan 1 0 0 0 1 0 1\n3 0 1 3\n"),
            ),
        ];
        for (name, text) in cases {
            let e = load_ply(&temp_file(name, text.as_bytes()), &loc()).unwrap_err();
            assert!(e.to_string().contains(name), "{name}: {e}");
        }
    }
}
