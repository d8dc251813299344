//! The GMM guide's snapshot: both mixtures with the statistics they were fitted from (so that training
//! can continue), p_div, the box and the update count; not the configuration, which the loader gives.

use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

use super::em::SuffStats;
use super::gaussian::Gaussian3;
use super::guide::{GmmGuide, MixtureState};
use super::mixture::Mixture;
use super::sym3::Sym3;
use super::GmmConfig;
use crate::snapshot::{decode, encode};
use crate::Aabb3;

/// Magic prefix of the GMM guide's snapshots.
pub const GMM_SNAPSHOT_MAGIC: [u8; 8] = *b"FOCALGMM";
/// Version of the snapshot layout (9: the model without the configuration, the origin models and the
/// selection grid, which a [`crate::SelectionLayer`] saves).
const SNAPSHOT_VERSION: u32 = 9;

/// The snapshot's body (mixtures in the unit frame).
#[derive(Serialize, Deserialize)]
struct Snapshot {
    aabb_min: [f32; 3],
    aabb_max: [f32; 3],
    p_div: f64,
    updates: u32,
    conv: SavedMixture,
    div: SavedMixture,
}

/// One mixture in a snapshot, with its statistics.
#[derive(Serialize, Deserialize)]
struct SavedMixture {
    weights: Vec<f64>,
    means: Vec<[f64; 3]>,
    covariances: Vec<[f64; 6]>,
    stats: Vec<SuffStats>,
}

impl SavedMixture {
    fn of(state: &MixtureState) -> Self {
        let m = &state.mixture;
        Self {
            weights: m.weights().to_vec(),
            means: m.components().iter().map(|g| g.mean().to_array()).collect(),
            covariances: m.components().iter().map(|g| g.covariance().0).collect(),
            stats: state.stats.clone(),
        }
    }

    fn into_state(self, k_max: usize) -> Result<MixtureState, String> {
        let k = self.weights.len();
        if self.means.len() != k || self.covariances.len() != k || self.stats.len() != k {
            return Err("GMM guide snapshot has inconsistent mixture lengths".into());
        }
        if k > k_max {
            return Err(format!(
                "GMM guide snapshot mixture has {k} components, more than em.k_max = {k_max}"
            ));
        }
        let components = self
            .means
            .iter()
            .zip(&self.covariances)
            .map(|(m, c)| Gaussian3::new(DVec3::from_array(*m), Sym3(*c)))
            .collect::<Option<Vec<_>>>()
            .ok_or("GMM guide snapshot has a non-positive-definite or non-finite component")?;
        if !self.stats.iter().all(SuffStats::is_valid) {
            return Err("GMM guide snapshot has invalid statistics".into());
        }
        let mixture = Mixture::from_normalized(self.weights, components)
            .map_err(|e| format!("GMM guide snapshot: {e}"))?;
        Ok(MixtureState {
            mixture,
            stats: self.stats,
        })
    }
}

impl GmmGuide {
    /// The guide's snapshot ([`crate::GuidingField::save`]).
    pub(super) fn snapshot(&self) -> Vec<u8> {
        let snapshot = Snapshot {
            aabb_min: self.aabb.min.to_array(),
            aabb_max: self.aabb.max.to_array(),
            p_div: self.p_div,
            updates: self.updates,
            conv: SavedMixture::of(&self.conv),
            div: SavedMixture::of(&self.div),
        };
        encode(GMM_SNAPSHOT_MAGIC, SNAPSHOT_VERSION, &snapshot)
    }

    /// Decodes a snapshot written by [`crate::GuidingField::save`], with `config` (the snapshot holds
    /// the model alone). Errors name what is wrong, never panic.
    pub fn load(bytes: &[u8], config: GmmConfig) -> Result<Self, String> {
        decode_snapshot(bytes, config)
    }
}

/// The guide of a snapshot, with `config`.
fn decode_snapshot(bytes: &[u8], config: GmmConfig) -> Result<GmmGuide, String> {
    let s: Snapshot = decode("GMM guide", GMM_SNAPSHOT_MAGIC, SNAPSHOT_VERSION, bytes)?;
    let aabb = Aabb3 {
        min: Vec3::from_array(s.aabb_min),
        max: Vec3::from_array(s.aabb_max),
    };
    if aabb.padded("GMM guide")? != aabb {
        return Err("GMM guide snapshot has a degenerate box".into());
    }
    if !(0.0..=1.0).contains(&s.p_div) {
        return Err(format!(
            "GMM guide snapshot has an invalid p_div {}",
            s.p_div
        ));
    }
    let mut guide = GmmGuide::new(aabb, config)?;
    guide.conv = s.conv.into_state(config.em.k_max)?;
    guide.div = s.div.into_state(config.em.k_max)?;
    guide.p_div = s.p_div;
    guide.updates = s.updates;
    Ok(guide)
}
