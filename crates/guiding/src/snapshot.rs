//! The versioned binary form every guide saves: an 8-byte magic naming the kind of snapshot, a layout
//! version, then the body (postcard). The header is read first, so that a snapshot of another kind or
//! of another layout version is refused with a message that says so, before its body is decoded.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// What every snapshot starts with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SnapshotHeader {
    /// Names the kind of snapshot (`FOCALOCT`, `FOCALGMM`, `FOCALGDE`).
    pub magic: [u8; 8],
    /// The layout version of that kind.
    pub version: u32,
}

impl SnapshotHeader {
    /// The header at the start of `bytes`, if they start with one.
    pub fn read(bytes: &[u8]) -> Option<SnapshotHeader> {
        postcard::take_from_bytes::<SnapshotHeader>(bytes)
            .ok()
            .map(|(h, _)| h)
    }
}

/// `body` behind the header (`magic`, `version`).
pub(crate) fn encode<T: Serialize>(magic: [u8; 8], version: u32, body: &T) -> Vec<u8> {
    let mut bytes = postcard::to_stdvec(&SnapshotHeader { magic, version })
        .expect("serialising plain data cannot fail");
    bytes.extend(postcard::to_stdvec(body).expect("serialising plain data cannot fail"));
    bytes
}

/// The body of a snapshot of `kind` ("octree guide", "GMM guide"), after checking its magic and
/// version: a snapshot of another kind, of an older or newer layout, or a truncated one is an error
/// that says which.
pub(crate) fn decode<T: DeserializeOwned>(
    kind: &str,
    magic: [u8; 8],
    version: u32,
    bytes: &[u8],
) -> Result<T, String> {
    let (header, body) = postcard::take_from_bytes::<SnapshotHeader>(bytes)
        .map_err(|e| format!("not {} {kind} snapshot: {e}", article(kind)))?;
    if header.magic != magic {
        return Err(format!("not {} {kind} snapshot (bad magic)", article(kind)));
    }
    if header.version < version {
        return Err(format!(
            "{kind} snapshot version {} was saved by an older focal; this one reads version {version} \
             (the layout changed): train and save the guide again",
            header.version
        ));
    }
    if header.version > version {
        return Err(format!(
            "{kind} snapshot version {} was saved by a newer focal; this one reads version {version}",
            header.version
        ));
    }
    let (value, rest) = postcard::take_from_bytes::<T>(body)
        .map_err(|e| format!("{kind} snapshot is damaged: {e}"))?;
    if !rest.is_empty() {
        return Err(format!(
            "{kind} snapshot is damaged: {} bytes after its end",
            rest.len()
        ));
    }
    Ok(value)
}

/// "an" before a vowel sound as the error messages spell them, "a" otherwise.
fn article(kind: &str) -> &'static str {
    if kind.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    }
}
