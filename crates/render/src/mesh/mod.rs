//! Triangle meshes read from files: the in-memory form ([`MeshData`]) and the OBJ and PLY loaders.
//!
//! Loaders return meshes in object space, validated (indices in range, finite values) and with
//! zero-area triangles removed; the builder applies `to_world` and computes vertex normals when the
//! file has none.

pub mod data;
pub mod obj;
pub mod ply;
pub mod serialized;

pub use data::MeshData;
pub use obj::load_obj;
pub use ply::load_ply;
pub use serialized::load_serialized;
