//! Mitsuba's `.serialized` mesh format (0.4–3.x): one or more zlib-compressed triangle meshes in one
//! file, with an end-of-file dictionary of their offsets; the scene's `shape_index` picks one.
//!
//! Layout of each mesh (little-endian): u16 format id 0x041C, u16 version (3 or 4), then a zlib stream
//! holding u32 flags, (version 4: a NUL-terminated UTF-8 name), u64 vertex count, u64 triangle count,
//! positions, optional normals, uvs and colours (f32, or f64 with the double-precision flag 0x2000), and the
//! triangle indices (u32, or u64 when there are more than 2³² vertices). The file ends with the
//! dictionary: one offset per mesh (u32 in version 3, u64 in version 4) and a u32 mesh count.

use super::obj::finish;
use super::MeshData;
use crate::error::{SceneError, SceneResult, SourceLoc};
use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};
use std::io::Read;
use std::path::Path;

const FORMAT_ID: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_UVS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const SINGLE_PRECISION: u32 = 0x1000;
const DOUBLE_PRECISION: u32 = 0x2000;

/// One mesh read from a `.serialized` file.
#[derive(Clone, Debug, PartialEq)]
pub struct SerializedMesh {
    /// The mesh (vertex colours are read but not kept).
    pub data: MeshData,
    /// The mesh's name (version 4 files), or empty.
    pub name: String,
    /// The file asks for face normals (its `FaceNormals` flag).
    pub face_normals: bool,
}

/// Loads mesh `shape_index` of a `.serialized` file. `loc` is where the scene names the file.
pub fn load_serialized(
    path: &Path,
    loc: &SourceLoc,
    shape_index: i64,
) -> SceneResult<SerializedMesh> {
    let bytes = std::fs::read(path).map_err(|e| {
        SceneError::at(
            loc,
            format!("cannot read serialized mesh '{}': {e}", path.display()),
        )
    })?;
    let mut mesh = parse_serialized(&bytes, shape_index).map_err(|e| {
        SceneError::at(
            loc,
            format!(
                "serialized mesh '{}' (shape_index {shape_index}): {e}",
                path.display()
            ),
        )
    })?;
    mesh.data = finish(mesh.data, path, loc, "serialized")?;
    Ok(mesh)
}

/// Parses mesh `shape_index` out of the bytes of a `.serialized` file. Every malformed input is an
/// error describing what is wrong (never a panic, and never an allocation larger than the input allows).
pub fn parse_serialized(bytes: &[u8], shape_index: i64) -> Result<SerializedMesh, String> {
    let (version, offset) = locate(bytes, shape_index)?;
    let mut header = Cursor::new(&bytes[offset..]);
    let format = header.u16()?;
    let v = header.u16()?;
    if format != FORMAT_ID {
        return Err(format!(
            "bad format id 0x{format:04X} at byte {offset} (expected 0x041C)"
        ));
    }
    if v != version {
        return Err(format!(
            "mesh at byte {offset} has version {v}, the file's first mesh {version}"
        ));
    }
    // The decompressed size is bounded by zlib's maximum ratio (~1032:1); reading into a Vec grows it as
    // data arrives, so a lying count cannot make us allocate more than the stream really holds.
    let mut raw = Vec::new();
    ZlibDecoder::new(&bytes[offset + 4..])
        .read_to_end(&mut raw)
        .map_err(|e| format!("corrupt zlib stream at byte {}: {e}", offset + 4))?;
    parse_mesh(&raw, version)
}

/// Finds the file's version and the byte offset of mesh `shape_index`.
fn locate(bytes: &[u8], shape_index: i64) -> Result<(u16, usize), String> {
    let mut c = Cursor::new(bytes);
    if c.u16()? != FORMAT_ID {
        return Err("not a Mitsuba serialized mesh (bad format id)".into());
    }
    let version = c.u16()?;
    if version != 3 && version != 4 {
        return Err(format!(
            "unsupported serialized format version {version} (3 and 4 are known)"
        ));
    }
    if bytes.len() < 8 {
        return Err("file too short for the end-of-file dictionary".into());
    }
    let count = u32::from_le_bytes(bytes[bytes.len() - 4..].try_into().expect("4 bytes")) as u64;
    if shape_index < 0 || shape_index as u64 >= count {
        return Err(format!(
            "shape_index {shape_index} is out of range: the file holds {count} mesh(es)"
        ));
    }
    let width: u64 = if version == 4 { 8 } else { 4 };
    let table = count
        .checked_mul(width)
        .and_then(|t| t.checked_add(4))
        .filter(|&t| t <= bytes.len() as u64)
        .ok_or_else(|| format!("dictionary of {count} meshes does not fit in the file"))?;
    let entry = bytes.len() - table as usize + (shape_index as u64 * width) as usize;
    let mut c = Cursor::new(&bytes[entry..]);
    let offset = if version == 4 {
        c.u64()?
    } else {
        c.u32()? as u64
    };
    if offset.saturating_add(4) > bytes.len() as u64 - table {
        return Err(format!(
            "mesh offset {offset} points past the mesh data ({} bytes)",
            bytes.len() as u64 - table
        ));
    }
    Ok((version, offset as usize))
}

fn parse_mesh(raw: &[u8], version: u16) -> Result<SerializedMesh, String> {
    let mut c = Cursor::new(raw);
    let flags = c.u32()?;
    // As Mitsuba: f64 data iff the double-precision flag is set (old writers set other bits, e.g.
    // 0x0100, instead of the single-precision flag).
    let double = flags & DOUBLE_PRECISION != 0;
    let name = if version == 4 {
        let end = raw[c.pos..]
            .iter()
            .position(|&b| b == 0)
            .ok_or("unterminated mesh name")?;
        let name = String::from_utf8_lossy(&raw[c.pos..c.pos + end]).into_owned();
        c.pos += end + 1;
        name
    } else {
        String::new()
    };
    let vertex_count = c.u64()?;
    let triangle_count = c.u64()?;
    let scalar = if double { 8 } else { 4 };
    let per_vertex = scalar
        * (3 + 3 * u64::from(flags & HAS_NORMALS != 0)
            + 2 * u64::from(flags & HAS_UVS != 0)
            + 3 * u64::from(flags & HAS_COLORS != 0));
    let index_width: u64 = if vertex_count > u32::MAX as u64 { 8 } else { 4 };
    let needed = vertex_count
        .checked_mul(per_vertex)
        .and_then(|v| triangle_count.checked_mul(3 * index_width)?.checked_add(v));
    match needed {
        Some(n) if n <= c.remaining() as u64 => {}
        _ => {
            return Err(format!(
                "{vertex_count} vertices and {triangle_count} triangles need more data than the {} bytes \
                 left in the stream",
                c.remaining()
            ))
        }
    }
    let (nv, nt) = (vertex_count as usize, triangle_count as usize);
    let read_vec3 = |c: &mut Cursor| -> Result<Vec<Vec3>, String> {
        (0..nv)
            .map(|_| Ok(Vec3::new(c.real(double)?, c.real(double)?, c.real(double)?)))
            .collect()
    };
    let positions = read_vec3(&mut c)?;
    let normals = if flags & HAS_NORMALS != 0 {
        Some(read_vec3(&mut c)?)
    } else {
        None
    };
    let uvs = if flags & HAS_UVS != 0 {
        Some(
            (0..nv)
                .map(|_| Ok(Vec2::new(c.real(double)?, c.real(double)?)))
                .collect::<Result<Vec<_>, String>>()?,
        )
    } else {
        None
    };
    if flags & HAS_COLORS != 0 {
        read_vec3(&mut c)?;
    }
    let mut indices = Vec::with_capacity(nt);
    for t in 0..nt {
        let mut tri = [0u32; 3];
        for k in &mut tri {
            let i = if index_width == 8 {
                c.u64()?
            } else {
                c.u32()? as u64
            };
            if i >= vertex_count {
                return Err(format!(
                    "triangle {t} has vertex index {i}, but there are {vertex_count} vertices"
                ));
            }
            *k = u32::try_from(i).map_err(|_| "more than 2^32 vertices are not supported")?;
        }
        indices.push(tri);
    }
    Ok(SerializedMesh {
        data: MeshData {
            positions,
            normals,
            uvs,
            indices,
        },
        name,
        face_normals: flags & FACE_NORMALS != 0,
    })
}

/// A little-endian reader over a byte slice whose reads fail (rather than panic) at the end.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Cursor { bytes, pos: 0 }
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let b = self
            .bytes
            .get(self.pos..self.pos + N)
            .ok_or_else(|| format!("unexpected end of data at byte {}", self.pos))?;
        self.pos += N;
        Ok(b.try_into().expect("slice of length N"))
    }

    fn u16(&mut self) -> Result<u16, String> {
        self.take().map(u16::from_le_bytes)
    }

    fn u32(&mut self) -> Result<u32, String> {
        self.take().map(u32::from_le_bytes)
    }

    fn u64(&mut self) -> Result<u64, String> {
        self.take().map(u64::from_le_bytes)
    }

    fn real(&mut self, double: bool) -> Result<f32, String> {
        if double {
            self.take().map(|b| f64::from_le_bytes(b) as f32)
        } else {
            self.take().map(f32::from_le_bytes)
        }
    }
}

/// Writes meshes in the serialized format (version 3 or 4, single precision), for tests and tools.
pub fn write_serialized(meshes: &[(&MeshData, &str)], version: u16) -> Vec<u8> {
    use flate2::write::ZlibEncoder;
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for (m, name) in meshes {
        offsets.push(out.len() as u64);
        out.extend_from_slice(&FORMAT_ID.to_le_bytes());
        out.extend_from_slice(&version.to_le_bytes());
        let mut raw = Vec::new();
        let flags = SINGLE_PRECISION
            | if m.normals.is_some() { HAS_NORMALS } else { 0 }
            | if m.uvs.is_some() { HAS_UVS } else { 0 };
        raw.extend_from_slice(&flags.to_le_bytes());
        if version == 4 {
            raw.extend_from_slice(name.as_bytes());
            raw.push(0);
        }
        raw.extend_from_slice(&(m.positions.len() as u64).to_le_bytes());
        raw.extend_from_slice(&(m.indices.len() as u64).to_le_bytes());
        let mut put = |v: &[f32]| {
            for x in v {
                raw.extend_from_slice(&x.to_le_bytes());
            }
        };
        for p in &m.positions {
            put(&p.to_array());
        }
        for n in m.normals.iter().flatten() {
            put(&n.to_array());
        }
        for t in m.uvs.iter().flatten() {
            put(&t.to_array());
        }
        for t in &m.indices {
            for i in t {
                raw.extend_from_slice(&i.to_le_bytes());
            }
        }
        let mut z = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).expect("writing to a Vec");
        out.extend_from_slice(&z.finish().expect("writing to a Vec"));
    }
    for o in &offsets {
        if version == 4 {
            out.extend_from_slice(&o.to_le_bytes());
        } else {
            out.extend_from_slice(&(*o as u32).to_le_bytes());
        }
    }
    out.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> MeshData {
        MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
            indices: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    fn triangle() -> MeshData {
        MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2]],
        }
    }

    #[test]
    fn round_trips_both_versions_and_picks_shape_index() {
        for version in [3, 4] {
            let (q, t) = (quad(), triangle());
            let bytes = write_serialized(&[(&q, "quad"), (&t, "tri")], version);
            let a = parse_serialized(&bytes, 0).unwrap();
            let b = parse_serialized(&bytes, 1).unwrap();
            assert_eq!(a.data, q);
            assert_eq!(b.data, t);
            assert_eq!(b.name, if version == 4 { "tri" } else { "" });
            let e = parse_serialized(&bytes, 2).unwrap_err();
            assert!(e.contains("out of range") && e.contains("2 mesh"), "{e}");
        }
    }

    #[test]
    fn corrupt_files_are_errors() {
        let q = quad();
        let bytes = write_serialized(&[(&q, "")], 3);
        assert!(parse_serialized(&bytes[..3], 0).is_err());
        assert!(parse_serialized(&[], 0).is_err());
        for cut in [5, 20, bytes.len() - 5] {
            let mut b = bytes[..cut].to_vec();
            b.extend_from_slice(&1u32.to_le_bytes());
            assert!(parse_serialized(&b, 0).is_err(), "cut at {cut}");
        }
        let mut b = bytes.clone();
        b[0] = 0;
        assert!(parse_serialized(&b, 0).unwrap_err().contains("format id"));
    }
}
