//! [`GmmConfig`]: the GMM guide's parameters, nested by concern (EM, points, schedule, selection).
//!
//! A field missing from a serialised config takes its default, so a config can be given in part. The
//! command line names a field by its path (`em.iterations=2`); the flat names of earlier versions
//! (`em_iterations=2`) still work through [`GmmConfig::renamed`], and the parameters of removed
//! experiments are refused with the reason ([`GmmConfig::removed`]).

use serde::{Deserialize, Serialize};

use super::mixture::MAX_COMPONENTS;
use crate::{Schedule, SelectionLayerConfig};

/// User parameters of the GMM guide.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GmmConfig {
    /// The EM fit of each mixture.
    pub em: EmConfig,
    /// How training segments become rays and points for the fit.
    pub points: PointsConfig,
    /// Decay of the statistics and iterative narrowing ([`Schedule`]).
    pub schedule: Schedule,
    /// The selection layer a renderer puts over the guide ([`crate::SelectionLayer`]).
    pub selection: SelectionLayerConfig,
    /// Seed of the initialisation and of the points' stratification jitter.
    pub seed: u64,
    /// Opt-in experiments without a measured gain (the `experimental` cargo feature).
    #[cfg(feature = "experimental")]
    pub experimental: super::experimental::ExperimentalConfig,
}

/// Parameters of the stepwise MAP-EM fit ([`super::em::fit`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EmConfig {
    /// Components of each mixture's k-means++ initialisation.
    pub k_init: usize,
    /// Lower bound on components for merges and prunes.
    pub k_min: usize,
    /// Upper bound on components for splits (≤ [`MAX_COMPONENTS`]).
    pub k_max: usize,
    /// EM iterations per update (structure changes happen in the middle one).
    pub iterations: u32,
    /// Prior covariance scale σ₀ as a fraction of the box diagonal.
    pub prior_sigma: f64,
    /// Prior pseudo-weight as a fraction of each mixture's total training weight.
    pub prior_strength: f64,
    /// Floor on each mixture weight π_k.
    pub weight_floor: f64,
    /// Split a component when its weight share × binned KL divergence from its data exceeds this (nats).
    pub split_threshold: f64,
    /// Merge two components whose Bhattacharyya distance is below this.
    pub merge_threshold: f64,
    /// Prune components holding less than this share of their mixture's weight. Every component costs a
    /// term per shading point; 0.005 lost the bundled camera obscura's pinhole, whose component is still
    /// small in the first guided iterations (`gmm_learns_the_camera_obscura_pinhole`;
    /// `docs/experiments/2026-12-01-gmm-mixture-cost.md`).
    pub prune_share: f64,
}

/// How training segments become rays, and rays the weighted points EM fits ([`super::rays`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PointsConfig {
    /// Points drawn along each training ray (at least; see `min`).
    pub per_ray: u32,
    /// When there are few rays, draw up to 64 points per ray so that each mixture gets at least this
    /// many points: a sparse iteration (a few hundred rays through a pinhole) then still shows EM where
    /// its lines cross, instead of two points per line (`docs/experiments/2026-12-01-gmm-adaptive-points.md`).
    pub min: usize,
    /// Points per mixture and update; beyond it a deterministic stride subset of the rays is used, with
    /// correspondingly larger weights (bounds the fit time).
    pub max: usize,
    /// Rays kept per mixture in an iteration's sample storage; beyond it the storage is thinned to every
    /// other ray with doubled weight (bounds memory).
    pub max_rays: usize,
    /// Also train on the whole line through glass that bent the path by refraction
    /// ([`crate::TrainingSegment::refracting_endpoint`]: a ball or a lens, not a window), as Rath et al.
    /// do for every glossy endpoint. Off: behind a window the light is where the line through the glass
    /// points, so those lines are always extended; behind a lens it is not, and lines continued through
    /// a glass ball fan out beyond it (`docs/experiments/2026-12-02-lines-through-glass.md`).
    pub extend_through_refraction: bool,
}

impl Default for GmmConfig {
    fn default() -> Self {
        Self {
            em: EmConfig::default(),
            points: PointsConfig::default(),
            schedule: Schedule::default(),
            selection: SelectionLayerConfig::default(),
            seed: 0x6d6d_f0ca,
            #[cfg(feature = "experimental")]
            experimental: Default::default(),
        }
    }
}

impl Default for EmConfig {
    fn default() -> Self {
        Self {
            k_init: 8,
            k_min: 1,
            k_max: 64,
            iterations: 4,
            prior_sigma: 1e-3,
            prior_strength: 1e-4,
            weight_floor: 1e-4,
            split_threshold: 2e-3,
            merge_threshold: 0.05,
            prune_share: 1e-5,
        }
    }
}

impl Default for PointsConfig {
    fn default() -> Self {
        Self {
            per_ray: 2,
            min: 1 << 16,
            max: 1 << 17,
            max_rays: 2_000_000,
            extend_through_refraction: false,
        }
    }
}

/// The flat parameter names of earlier versions and the paths that replaced them.
const RENAMED: [(&str, &str); 24] = [
    ("k_init", "em.k_init"),
    ("k_min", "em.k_min"),
    ("k_max", "em.k_max"),
    ("em_iterations", "em.iterations"),
    ("prior_sigma", "em.prior_sigma"),
    ("prior_strength", "em.prior_strength"),
    ("weight_floor", "em.weight_floor"),
    ("split_threshold", "em.split_threshold"),
    ("merge_threshold", "em.merge_threshold"),
    ("prune_share", "em.prune_share"),
    ("points_per_ray", "points.per_ray"),
    ("min_points", "points.min"),
    ("max_points", "points.max"),
    ("max_rays", "points.max_rays"),
    (
        "extend_through_refraction",
        "points.extend_through_refraction",
    ),
    ("decay", "schedule.decay"),
    ("narrowing", "schedule.narrowing"),
    ("narrowing_start", "schedule.narrowing_start"),
    ("guide_fraction", "selection.guide_fraction"),
    ("learn_selection", "selection.learn"),
    ("selection_by_share", "selection.by_share"),
    ("selection_min", "selection.min"),
    ("weight_power", "experimental.weight_power"),
    ("min_effective_rays", "experimental.min_effective_rays"),
];

/// The parameters of experiments that were removed, and where their record is.
const REMOVED: [(&str, &str); 8] = [
    ("sparse_prior_rays", "the sparse-data prior"),
    ("sparse_prior_sigma", "the sparse-data prior"),
    ("weight_truncation", "truncated training weights"),
    ("compensation", "MIS-compensated training weights"),
    ("condition_on_origins", "the origin model"),
    ("origin_floor", "the origin model"),
    ("origin_spread", "the origin model"),
    ("origin_min_sigma", "the origin model"),
];

/// Experimental parameters (behind the `experimental` cargo feature).
const EXPERIMENTAL: [&str; 2] = ["weight_power", "min_effective_rays"];

impl GmmConfig {
    /// The path that replaced an earlier flat parameter name (`em_iterations` → `em.iterations`).
    pub fn renamed(name: &str) -> Option<&'static str> {
        RENAMED
            .iter()
            .find(|(old, _)| *old == name)
            .map(|(_, new)| *new)
    }

    /// Why a parameter name is not (or no longer) accepted in this build, if it is one of a removed
    /// experiment's or an experimental one without the `experimental` feature.
    pub fn removed(name: &str) -> Option<String> {
        let leaf = name.rsplit('.').next().unwrap_or(name);
        if let Some((_, what)) = REMOVED.iter().find(|(n, _)| *n == leaf) {
            return Some(format!(
                "`{name}` belonged to {what}, an experiment without a measured gain that was removed \
                 (see docs/experiments/2026-12-07-redesign.md)"
            ));
        }
        if !cfg!(feature = "experimental") && EXPERIMENTAL.contains(&leaf) {
            return Some(format!(
                "`{name}` is experimental: build focal with `--features focal-guiding/experimental`"
            ));
        }
        None
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), String> {
        let fail = |what: &str| Err(format!("invalid GMM guide config: {what} ({self:?})"));
        let em = &self.em;
        if !(1 <= em.k_min && em.k_min <= em.k_max && em.k_max <= MAX_COMPONENTS) {
            return fail("need 1 <= em.k_min <= em.k_max <= 128");
        }
        if !(1 <= em.k_init && em.k_init <= em.k_max) {
            return fail("need 1 <= em.k_init <= em.k_max");
        }
        if !(1..=100).contains(&em.iterations) {
            return fail("em.iterations must lie in 1..=100");
        }
        if !(em.prior_sigma > 0.0 && em.prior_sigma < 1.0) {
            return fail("em.prior_sigma must lie in (0, 1)");
        }
        if !(em.prior_strength >= 0.0 && em.prior_strength <= 1.0) {
            return fail("em.prior_strength must lie in [0, 1]");
        }
        if !(em.weight_floor >= 0.0 && em.weight_floor * (em.k_max as f64) < 0.5) {
            return fail("em.weight_floor must be >= 0 and below 0.5 / em.k_max");
        }
        if !(em.split_threshold >= 0.0) || !(em.merge_threshold >= 0.0) {
            return fail("split and merge thresholds must be >= 0 (infinity disables splits)");
        }
        if !(0.0..1.0).contains(&em.prune_share) {
            return fail("em.prune_share must lie in [0, 1)");
        }
        let p = &self.points;
        if !(1..=256).contains(&p.per_ray) {
            return fail("points.per_ray must lie in 1..=256");
        }
        if p.max == 0 || p.max_rays < 2 {
            return fail("points.max must be positive and points.max_rays at least 2");
        }
        self.schedule.validate("GMM guide")?;
        self.selection.validate()?;
        #[cfg(feature = "experimental")]
        self.experimental.validate()?;
        Ok(())
    }
}
