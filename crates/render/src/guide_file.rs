//! Guide files bound to their scene: a trained guide's snapshot ([`GuidingField::save`]) behind a
//! small header naming the scene it was trained on, a fingerprint of that scene's geometry and lights,
//! and the method. Loading a guide into another scene is then refused by the front end (a guide learned
//! elsewhere is unbiased but useless, and nothing would say so), and the method comes from the file.
//!
//! Layout: `FOCALGDF`, a little-endian u32 version, a little-endian u32 header length, the header
//! (postcard), then the snapshot. Bare snapshots (files saved before the header existed) still load,
//! without a scene to check.

use crate::guide::{load_guide, GuideParams, GuidingMethod};
use crate::render::reference::fnv1a64;
use crate::scene::Scene;
use focal_guiding::GuidingField;
use serde::{Deserialize, Serialize};

const MAGIC: &[u8; 8] = b"FOCALGDF";
const VERSION: u32 = 1;

/// Where a guide was trained.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GuideOrigin {
    /// The scene file as it was given to the training render (for messages; paths differ between
    /// machines, so only the fingerprint is compared).
    pub scene: String,
    /// [`scene_fingerprint`] of the scene it was trained on.
    pub fingerprint: u64,
    /// The guide's method.
    pub method: GuidingMethod,
}

/// A guide file read and checked: its method and origin, and the snapshot, which becomes a guide with
/// the configuration of the render that uses it ([`GuideFile::guide`]; a snapshot holds the model
/// alone).
pub struct GuideFile {
    /// The guide's method (from the snapshot itself).
    pub method: GuidingMethod,
    /// Where it was trained; `None` for a bare snapshot without the header.
    pub origin: Option<GuideOrigin>,
    snapshot: Vec<u8>,
}

impl GuideFile {
    /// The guide, with `params` for everything the snapshot does not hold.
    pub fn guide(&self, params: &GuideParams) -> Result<Box<dyn GuidingField>, String> {
        load_guide(&self.snapshot, params)
    }
}

/// A fingerprint of what a guide learns from: the scene's bounds (the guide's box), every shape's bounds
/// and which shapes emit, and the lights. Film size, sampler, integrator and materials do not enter, so
/// a guide trained at a low resolution serves a high-resolution render of the same scene.
pub fn scene_fingerprint(scene: &Scene) -> u64 {
    let mut words: Vec<u32> = Vec::new();
    let bounds = |b: &crate::geometry::Aabb, words: &mut Vec<u32>| {
        for v in [b.min, b.max] {
            words.extend(v.to_array().map(f32::to_bits));
        }
    };
    bounds(&scene.bounds, &mut words);
    words.push(scene.geometries.len() as u32);
    for (g, s) in scene.geometries.iter().zip(&scene.shapes) {
        bounds(&g.bounds(), &mut words);
        words.push(s.emitter.map_or(u32::MAX, |e| e));
    }
    words.push(scene.emitters.len() as u32);
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    fnv1a64(&[&bytes])
}

/// The bytes of a guide file: the header of `origin`, then the guide's snapshot.
pub fn guide_file_bytes(guide: &dyn GuidingField, origin: &GuideOrigin) -> Vec<u8> {
    let header = postcard::to_allocvec(origin).expect("a guide header serialises");
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(header.len() as u32).to_le_bytes());
    out.extend_from_slice(&header);
    out.extend_from_slice(&guide.save());
    out
}

/// Reads a guide file (or a bare snapshot); the method is recognised from the snapshot.
pub fn read_guide_file(bytes: &[u8]) -> Result<GuideFile, String> {
    let (origin, snapshot) = match bytes.strip_prefix(MAGIC) {
        None => (None, bytes),
        Some(rest) => {
            let word = |b: &[u8], at: usize| -> Option<u32> {
                Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
            };
            let (Some(version), Some(len)) = (word(rest, 0), word(rest, 4)) else {
                return Err("truncated guide file header".to_string());
            };
            if version != VERSION {
                return Err(format!(
                    "guide file version {version}, this focal reads version {VERSION}"
                ));
            }
            let header = rest
                .get(8..8 + len as usize)
                .ok_or("truncated guide file header")?;
            let origin: GuideOrigin =
                postcard::from_bytes(header).map_err(|e| format!("bad guide file header: {e}"))?;
            (Some(origin), &rest[8 + len as usize..])
        }
    };
    // Decoded once here, so that a damaged snapshot is reported when the file is read.
    let guide = load_guide(snapshot, &GuideParams::default())?;
    let method = GuidingMethod::parse(guide.name())?;
    if let Some(o) = &origin {
        if o.method != method {
            return Err(format!(
                "the header says {} but the snapshot is a {} guide",
                o.method.name(),
                method.name()
            ));
        }
    }
    Ok(GuideFile {
        method,
        origin,
        snapshot: snapshot.to_vec(),
    })
}
