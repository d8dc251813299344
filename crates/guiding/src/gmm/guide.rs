//! [`GmmGuide`]: focal path guiding with a converging and a diverging spatial Gaussian mixture
//! (`docs/design/gmm.md`), implementing [`GuidingDistribution`].
//!
//! Internally everything lives in a *unit frame*: y_u = (y − c)/h with c the box centre and h half its
//! largest extent, so the box fits in [−1, 1]³. The directional pdf is invariant under this isotropic
//! change of units (t² dt dω scales like the density's 1/h³), and the EM statistics, the prior and the
//! covariance floor get scene-independent magnitudes.

use std::time::Instant;

use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};

use super::cumulative::pick_interval;
use super::em::{fit, FitParams, FitReport, SuffStats};
use super::gaussian::Gaussian3;
use super::mixture::{Mixture, MAX_COMPONENTS, TERMS_PER_COMPONENT};
use super::origins::{fit_origins, OriginModel, OriginParams};
use super::rays::{
    clip_to_box, generate_points, mix64, NarrowingTable, PointSampling, TrainingRay,
};
use super::reflected::ReflectedRadiance;
use super::special::open_unit;
use super::sym3::Sym3;
use super::truncated::sample_half_space;
use crate::distribution::check_snapshot_header;
use crate::{
    Aabb3, GuideSample, GuideVertex, GuidingDistribution, SelectionConfig, SelectionGrid,
    SelectionRule, TrainingSegment, UpdateContext, UpdateStats,
};

/// The decay of the online statistics once iterative narrowing starts (as the octree's).
pub const NARROWING_DECAY: f64 = 0.25;
/// With a `normal`, a hemisphere holding less guide mass than this is treated as empty (`sample`
/// returns `None`, `pdf` 0): guiding into it would only chase the mixture's far tails.
pub const MIN_HEMISPHERE_MASS: f64 = 1e-6;
/// A mixture holding less than this share of the total (decayed + new) training weight is dropped: it
/// would cost as much per pdf evaluation as a useful one while adding nothing to the sampling
/// (observed: docs/experiments/2026-12-01-gmm-mixture-cost.md).
pub const MIN_MIXTURE_SHARE: f64 = 1e-3;
/// `f32` kernel terms per mixture in a [`GuideVertex`]'s `buffer32`: the converging mixture's block,
/// then the diverging one's.
const KERNEL_TERMS_BLOCK: usize = TERMS_PER_COMPONENT * MAX_COMPONENTS;
/// The most points drawn along one ray when rays are few (`GmmConfig::min_points`).
const MAX_ADAPTIVE_POINTS_PER_RAY: usize = 64;
/// Magic prefix of [`GmmGuide::save`] snapshots.
const SNAPSHOT_MAGIC: [u8; 8] = *b"FOCALGMM";
/// Version of the snapshot layout.
const SNAPSHOT_VERSION: u32 = 8;

/// User parameters of the GMM guide (fields missing from a serialised config take their defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GmmConfig {
    /// Components of each mixture's k-means++ initialisation.
    pub k_init: usize,
    /// Lower bound on components for merges and prunes.
    pub k_min: usize,
    /// Upper bound on components for splits (≤ [`MAX_COMPONENTS`]).
    pub k_max: usize,
    /// EM iterations per update (structure changes happen in the middle one).
    pub em_iterations: u32,
    /// Points drawn along each training ray (at least; see `min_points`).
    pub points_per_ray: u32,
    /// When there are few rays, draw up to 64 points per ray so that each mixture gets at least this many
    /// points: a sparse iteration (a few hundred rays through a pinhole) then still shows EM where its
    /// lines cross, instead of two points per line.
    pub min_points: usize,
    /// Points per mixture and update; beyond it a deterministic stride subset of the rays is used, with
    /// correspondingly larger weights (bounds the fit time).
    pub max_points: usize,
    /// Rays buffered per mixture between updates; beyond it the buffer is thinned to every other ray with
    /// doubled weight (bounds memory).
    pub max_rays: usize,
    /// Decay of the online statistics per update before iterative narrowing (afterwards 0.25).
    pub decay: f64,
    /// Use iterative narrowing from iteration ⌊`narrowing_start`·N⌋ (the continuous RAY_WEIGHTED splat).
    pub narrowing: bool,
    /// The share of the N training iterations before narrowing (and its decay) starts: from iteration
    /// ⌊share·N⌋ (Rath et al.: 2/3).
    pub narrowing_start: f64,
    /// Prior covariance scale σ₀ as a fraction of the box diagonal.
    pub prior_sigma: f64,
    /// Prior pseudo-weight as a fraction of each mixture's total training weight.
    pub prior_strength: f64,
    /// Pseudo-rays of a second covariance prior (σ = `sparse_prior_sigma`) for sparse data: its
    /// pseudo-weight is this many times the mixture's weight per effective ray, (Σm)²/Σm² over the
    /// rays' masses m = c·length (decayed across updates as the statistics are), i.e. a share
    /// `sparse_prior_rays`/n_eff of the training weight (at most 1); it adds to the base prior as one
    /// conjugate prior. Meant for sparse, heavy-tailed data such as sms-ring's caustic (an effective 3–7
    /// rays per update). Opt-in (0, the default, disables it): it helps sms-ring but blurs the camera
    /// obscuras' pinhole (docs/experiments/2026-12-04-sms-ring-gmm-guide.md).
    pub sparse_prior_rays: f64,
    /// σ of the sparse-data prior as a fraction of the box diagonal.
    pub sparse_prior_sigma: f64,
    /// Floor on each mixture weight π_k.
    pub weight_floor: f64,
    /// Split a component when its weight share × binned KL divergence from its data exceeds this (nats).
    pub split_threshold: f64,
    /// Merge two components whose Bhattacharyya distance is below this.
    pub merge_threshold: f64,
    /// Prune components holding less than this share of their mixture's weight: every component costs a
    /// term per shading point. Kept small because a pinhole's component is still small in the first
    /// guided iterations: 0.005 loses the bundled camera obscura's pinhole
    /// (docs/experiments/2026-12-01-gmm-mixture-cost.md).
    pub prune_share: f64,
    /// Seed of the initialisation and of the points' stratification jitter.
    pub seed: u64,
    /// The probability of sampling this guide rather than the BSDF that the guide asks a renderer for
    /// ([`GuidingDistribution::selection_probability`]; a fraction the user gives the renderer wins).
    /// 0.75 rather than Rath et al.'s 0.5: the exact, hemisphere-truncated pdf can be leaned on harder
    /// (0.59× the relMSE of 0.5 at equal time: docs/experiments/2026-12-01-gmm-guide-fraction.md).
    pub guide_fraction: f32,
    /// Learn the fraction per region of space ([`SelectionGrid`]) for the final render (training
    /// iterations keep `guide_fraction`), so that regions lit by other paths (the door gap's lit room)
    /// stop spending 0.75 on the guide. On by default, with the share rule and `selection_min` 0.4
    /// (docs/experiments/2026-12-03-learned-selection-default.md); the second-moment rule
    /// ([`TrainingSegment::second_moment_with_fraction`]) lost to the fixed fraction
    /// (docs/experiments/2026-12-01-selection-second-moment.md).
    pub learn_selection: bool,
    /// With `learn_selection`, choose each region's fraction as the share of its contribution that
    /// arrives from directions the guide covers ([`SelectionRule::ContributionShare`]), between
    /// `selection_min` and `guide_fraction`, rather than by least second moment; glossy vertices keep
    /// `guide_fraction` and do not teach the grid (on the torus's rough glass the share is near 0, but
    /// the fixed fraction wins: docs/experiments/2026-12-02-selection-share-rule.md).
    pub selection_by_share: bool,
    /// The least fraction the share rule chooses (at most `guide_fraction`). 0.4 rather than 0.1: lower
    /// floors starved the lens focus and the shaded lights, whose diffuse receivers see their light
    /// through a caustic the guide covers but still finds rarely
    /// (docs/experiments/2026-12-02-selection-share-rule.md).
    pub selection_min: f32,
    /// Also train on the whole line through glass that bent the path by refraction
    /// ([`crate::TrainingSegment::refracting_endpoint`]: a ball or a lens, not a window), as Rath et al.
    /// do for every glossy endpoint. Off by default: such segments are trained on as segments. Behind a
    /// window the light is where the line through the glass points, so those lines are always extended;
    /// behind a lens it is not, and the lines continued through a glass ball fan out beyond it
    /// (docs/experiments/2026-12-02-lines-through-glass.md).
    pub extend_through_refraction: bool,
    /// κ of MIS-compensated training weights ([`ReflectedRadiance`]; Karlík et al. 2019): each
    /// segment is fitted with max(0, c − κ·T·L_o·p_bsdf/p_mix) instead of its contribution c, T the path
    /// throughput at its origin and L_o the mean radiance the shading points of that region reflect,
    /// so that the mixture holds what BSDF sampling does not already find (a pinhole, not the room its
    /// light bounces around in); 0 (the default) fits c (Rath et al.). Glossy origins are not
    /// compensated. Opt-in (`--gmm compensation=1`): at equal time it was within the noise of the
    /// uncompensated fit (docs/experiments/2026-12-04-compensation.md). It keeps the obscura's pinhole
    /// (`gmm_with_compensated_weights_learns_the_camera_obscura_pinhole`).
    pub compensation: f64,
    /// Weigh the components at each shading point by where their training rays started
    /// ([`OriginModel`]): c_k(x) = (1 − β)·W_k O_k(x)/Σ_j W_j O_j(x) + β·π_k instead of π_k, so that a
    /// shading point prefers the foci its neighbourhood's light went through. Off by default: at equal
    /// time it has not beaten the global weights reproducibly, at about 10 % fewer samples
    /// (docs/experiments/2026-12-02-origin-model.md).
    pub condition_on_origins: bool,
    /// β of the origin model: the share of the global weights kept everywhere.
    pub origin_floor: f64,
    /// Factor on the covariance of each component's ray origins.
    pub origin_spread: f64,
    /// Least standard deviation of an origin Gaussian, as a fraction of the box's largest half-extent.
    pub origin_min_sigma: f64,
    /// β of tempered training weights: each update's rays are fitted with c^β instead of c, rescaled so
    /// that each mixture's total mass is unchanged (1, the default, fits c as Rath et al. do). Below 1
    /// a few heavy rays (a caustic's fireflies) no longer decide the fit alone (first look:
    /// docs/experiments/2026-12-06-clamped-training-weights.md).
    pub weight_power: f64,
    /// Clamp each update's heaviest training rays (per mixture) so that at least this many rays stand
    /// behind the fit by weight, (Σm)²/Σm² over the masses m = c·length (fewer if there are fewer rays),
    /// keeping the total mass; 0 (the default) leaves the weights alone (first look:
    /// docs/experiments/2026-12-06-clamped-training-weights.md).
    pub min_effective_rays: f64,
    /// Truncated importance weights (Ionides 2008): each update's training weights are clamped at this
    /// factor times √N times their mean (N the mixture's rays in the update), keeping the total mass;
    /// 0 (the default) leaves them alone. Not measured yet.
    pub weight_truncation: f64,
}

impl Default for GmmConfig {
    fn default() -> Self {
        Self {
            k_init: 8,
            k_min: 1,
            k_max: 64,
            em_iterations: 4,
            points_per_ray: 2,
            min_points: 1 << 16,
            max_points: 1 << 17,
            max_rays: 2_000_000,
            decay: 0.5,
            narrowing: true,
            narrowing_start: 2.0 / 3.0,
            prior_sigma: 1e-3,
            prior_strength: 1e-4,
            sparse_prior_rays: 0.0,
            sparse_prior_sigma: 0.05,
            weight_floor: 1e-4,
            split_threshold: 2e-3,
            merge_threshold: 0.05,
            prune_share: 1e-5,
            seed: 0x6d6d_f0ca,
            guide_fraction: 0.75,
            learn_selection: true,
            selection_by_share: true,
            selection_min: 0.4,
            extend_through_refraction: false,
            compensation: 0.0,
            condition_on_origins: false,
            origin_floor: 0.5,
            origin_spread: 2.0,
            origin_min_sigma: 0.05,
            weight_power: 1.0,
            min_effective_rays: 0.0,
            weight_truncation: 0.0,
        }
    }
}

impl GmmConfig {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), String> {
        let fail = |what: &str| Err(format!("invalid GMM guide config: {what} ({self:?})"));
        if !(1 <= self.k_min && self.k_min <= self.k_max && self.k_max <= MAX_COMPONENTS) {
            return fail("need 1 <= k_min <= k_max <= 128");
        }
        if !(1 <= self.k_init && self.k_init <= self.k_max) {
            return fail("need 1 <= k_init <= k_max");
        }
        if !(1..=100).contains(&self.em_iterations) {
            return fail("em_iterations must lie in 1..=100");
        }
        if !(1..=256).contains(&self.points_per_ray) {
            return fail("points_per_ray must lie in 1..=256");
        }
        if self.max_points == 0 || self.max_rays < 2 {
            return fail("max_points must be positive and max_rays at least 2");
        }
        if !(0.0..=1.0).contains(&self.decay) {
            return fail("decay must lie in [0, 1]");
        }
        if !(self.prior_sigma > 0.0 && self.prior_sigma < 1.0) {
            return fail("prior_sigma must lie in (0, 1)");
        }
        if !(self.prior_strength >= 0.0 && self.prior_strength <= 1.0) {
            return fail("prior_strength must lie in [0, 1]");
        }
        if !(self.sparse_prior_rays >= 0.0 && self.sparse_prior_rays.is_finite()) {
            return fail("sparse_prior_rays must be finite and >= 0");
        }
        if !(self.sparse_prior_sigma > 0.0 && self.sparse_prior_sigma < 1.0) {
            return fail("sparse_prior_sigma must lie in (0, 1)");
        }
        if !(self.weight_floor >= 0.0 && self.weight_floor * (self.k_max as f64) < 0.5) {
            return fail("weight_floor must be >= 0 and below 0.5 / k_max");
        }
        if !(self.split_threshold >= 0.0) || !(self.merge_threshold >= 0.0) {
            return fail("split and merge thresholds must be >= 0 (infinity disables splits)");
        }
        if !(self.weight_power > 0.0 && self.weight_power <= 1.0) {
            return fail("weight_power must lie in (0, 1]");
        }
        if !(self.min_effective_rays >= 0.0 && self.min_effective_rays.is_finite()) {
            return fail("min_effective_rays must be finite and >= 0");
        }
        if !(self.weight_truncation >= 0.0 && self.weight_truncation.is_finite()) {
            return fail("weight_truncation must be finite and >= 0");
        }
        if !(0.0..1.0).contains(&self.prune_share) {
            return fail("prune_share must lie in [0, 1)");
        }
        if !(self.selection_min > 0.0 && self.selection_min < 1.0) {
            return fail("selection_min must lie in (0, 1)");
        }
        if !(self.guide_fraction > 0.0 && self.guide_fraction < 1.0) {
            return fail("guide_fraction must lie in (0, 1)");
        }
        if !(0.0..=1.0).contains(&self.narrowing_start) {
            return fail("narrowing_start must lie in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.origin_floor) {
            return fail("origin_floor must lie in [0, 1]");
        }
        if !(self.origin_spread >= 1.0 && self.origin_spread.is_finite()) {
            return fail("origin_spread must be finite and at least 1");
        }
        if !(self.origin_min_sigma > 0.0 && self.origin_min_sigma.is_finite()) {
            return fail("origin_min_sigma must be positive");
        }
        Ok(())
    }
}

/// One mixture and the online statistics it was fitted from (unit frame).
#[derive(Clone, Debug, Default, PartialEq)]
struct MixtureState {
    mixture: Mixture,
    stats: Vec<SuffStats>,
}

impl MixtureState {
    fn weight(&self) -> f64 {
        self.stats.iter().map(|s| s.weight).sum()
    }
}

/// Training rays recorded since the last update.
#[derive(Clone, Debug, Default)]
struct Pending {
    conv: Vec<TrainingRay>,
    div: Vec<TrainingRay>,
    segments: u64,
    dropped: u64,
    empty: u64,
    thinned: u64,
}

/// Focal path guiding with two spatial Gaussian mixtures: a direction is drawn towards a point
/// y ~ ρ_conv (probability 1 − p_div) or away from a point y ~ ρ_div (probability p_div), and its pdf
/// (1 − p_div)·p_conv(x, ω) + p_div·p_div(x, −ω) is the exact half-line integral
/// (`docs/design/gmm.md`). With a `normal` both sampling and pdf are truncated to the hemisphere around
/// it. Untrained (before the first
/// update that saw data) it samples nothing and has pdf 0.
#[derive(Clone, Debug)]
pub struct GmmGuide {
    aabb: Aabb3,
    center: DVec3,
    scale: f64,
    config: GmmConfig,
    conv: MixtureState,
    div: MixtureState,
    p_div: f64,
    updates: u32,
    pending: Pending,
    selection: SelectionGrid,
    reflected: ReflectedRadiance,
    /// Effective numbers of rays behind the converging and diverging statistics (decayed as they are).
    effective_rays: [f64; 2],
    /// The last update prepared the final render (or the guide was loaded to render with): the learned
    /// selection, if enabled, applies.
    final_render: bool,
}

impl GmmGuide {
    /// An untrained guide over the scene box `aabb` (axes of zero extent are padded as the octree does).
    pub fn new(aabb: Aabb3, config: GmmConfig) -> Result<Self, String> {
        config.validate()?;
        let aabb = aabb.padded("GMM guide")?;
        let (center, scale) = unit_frame(aabb);
        Ok(Self {
            aabb,
            center,
            scale,
            config,
            conv: MixtureState::default(),
            div: MixtureState::default(),
            p_div: 0.0,
            updates: 0,
            pending: Pending::default(),
            selection: SelectionGrid::new(aabb, selection_config(&config))?,
            reflected: ReflectedRadiance::new(unit_box(aabb, center, scale)),
            effective_rays: [0.0; 2],
            final_render: false,
        })
    }

    /// A guide with given world-space mixtures (e.g. for tests or imported models). Each component's
    /// online statistics start as its moments with total weight 1 per mixture.
    pub fn from_mixtures(
        aabb: Aabb3,
        config: GmmConfig,
        converging: &Mixture,
        diverging: &Mixture,
        p_div: f64,
    ) -> Result<Self, String> {
        let mut guide = Self::new(aabb, config)?;
        if !(0.0..=1.0).contains(&p_div) {
            return Err(format!("p_div must lie in [0, 1], got {p_div}"));
        }
        for (state, mixture) in [(&mut guide.conv, converging), (&mut guide.div, diverging)] {
            if mixture.len() > config.k_max {
                return Err(format!(
                    "a mixture of {} components exceeds k_max = {}",
                    mixture.len(),
                    config.k_max
                ));
            }
            let unit = mixture.transformed(guide.center, guide.scale)?;
            state.stats = unit
                .weights()
                .iter()
                .zip(unit.components())
                .map(|(w, g)| SuffStats {
                    weight: *w,
                    mean: g.mean(),
                    scatter: g.covariance() * *w,
                })
                .collect();
            state.mixture = unit;
        }
        guide.p_div = p_div;
        Ok(guide)
    }

    /// The (padded) scene box.
    pub fn aabb(&self) -> Aabb3 {
        self.aabb
    }

    /// The unit frame: y_unit = (y − centre) / scale.
    pub fn unit_frame(&self) -> (DVec3, f64) {
        (self.center, self.scale)
    }

    /// The user parameters.
    pub fn config(&self) -> GmmConfig {
        self.config
    }

    /// Probability of sampling the diverging mixture: W_div / (W_conv + W_div) of the last update.
    pub fn p_div(&self) -> f64 {
        self.p_div
    }

    /// True once a mixture holds components (sampling and pdf are active).
    pub fn is_trained(&self) -> bool {
        !self.conv.mixture.is_empty() || !self.div.mixture.is_empty()
    }

    /// Updates applied so far.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// The converging mixture in world coordinates (for visualisation).
    pub fn converging(&self) -> Mixture {
        self.world(&self.conv.mixture)
    }

    /// The diverging mixture in world coordinates (for visualisation).
    pub fn diverging(&self) -> Mixture {
        self.world(&self.div.mixture)
    }

    /// The converging mixture in the unit frame, as sampled.
    pub fn converging_unit(&self) -> &Mixture {
        &self.conv.mixture
    }

    /// The diverging mixture in the unit frame, as sampled.
    pub fn diverging_unit(&self) -> &Mixture {
        &self.div.mixture
    }

    /// The online statistics behind (converging, diverging) mixtures, unit frame.
    pub fn statistics(&self) -> (&[SuffStats], &[SuffStats]) {
        (&self.conv.stats, &self.div.stats)
    }

    /// Buffered (converging, diverging) training rays waiting for the next update.
    pub fn pending_rays(&self) -> (usize, usize) {
        (self.pending.conv.len(), self.pending.div.len())
    }

    fn world(&self, m: &Mixture) -> Mixture {
        m.untransformed(self.center, self.scale)
            .unwrap_or_else(|_| Mixture::empty())
    }

    #[inline]
    fn to_unit(&self, x: Vec3) -> DVec3 {
        (x.as_dvec3() - self.center) / self.scale
    }

    /// The untruncated pdf of unit `w` at unit-frame `x`.
    #[inline]
    fn full_pdf(&self, x: DVec3, w: DVec3) -> f64 {
        let q = self.p_div;
        let mut p = 0.0;
        if q < 1.0 {
            p += (1.0 - q) * self.conv.mixture.directional_pdf(x, w);
        }
        if q > 0.0 {
            p += q * self.div.mixture.directional_pdf(x, -w);
        }
        p
    }

    /// The untruncated pdf of unit `w` from the shading point whose kernel terms
    /// ([`GmmGuide::prepare_kernel`]) are `terms`: the renderer's `f32` kernel.
    #[inline]
    fn full_pdf_prepared(&self, terms: &[f32], w: DVec3) -> f64 {
        let q = self.p_div;
        let wf = [w.x as f32, w.y as f32, w.z as f32];
        let (conv, div) = terms.split_at(KERNEL_TERMS_BLOCK);
        let mut p = 0.0;
        if q < 1.0 {
            p += (1.0 - q) * self.conv.mixture.directional_pdf_prepared(conv, wf) as f64;
        }
        if q > 0.0 {
            let back = [-wf[0], -wf[1], -wf[2]];
            p += q * self.div.mixture.directional_pdf_prepared(div, back) as f64;
        }
        p
    }

    /// Fills `terms` (converging mixture first, then diverging, [`KERNEL_TERMS_BLOCK`] values each) with
    /// the per-component terms of the `f32` kernel at unit-frame `x` and, with a unit normal `n`,
    /// `masses` as [`GmmGuide::hemisphere_masses`] does (Φ in `f32`), returning Z (1 without a normal).
    #[inline]
    fn prepare_kernel(
        &self,
        x: DVec3,
        n: Option<DVec3>,
        terms: &mut Vec<f32>,
        masses: &mut Vec<f64>,
    ) -> f64 {
        terms.resize(2 * KERNEL_TERMS_BLOCK, 0.0);
        masses.resize(2 * MAX_COMPONENTS, 0.0);
        let (conv_terms, div_terms) = terms.split_at_mut(KERNEL_TERMS_BLOCK);
        let (conv_masses, div_masses) = masses.split_at_mut(MAX_COMPONENTS);
        let q = self.p_div;
        if q < 1.0 {
            let on_side = n.map(|n| (n, true));
            self.conv
                .mixture
                .prepare_vertex(x, on_side, conv_terms, conv_masses);
        }
        if q > 0.0 {
            let on_side = n.map(|n| (n, false));
            self.div
                .mixture
                .prepare_vertex(x, on_side, div_terms, div_masses);
        }
        match n {
            Some(_) => self.hemisphere_total(masses),
            None => 1.0,
        }
    }

    /// Z = (1 − p_div)·Σ_conv + p_div·Σ_div of the per-component hemisphere masses in `masses`
    /// (converging first, then diverging, [`MAX_COMPONENTS`] entries each).
    #[inline]
    fn hemisphere_total(&self, masses: &[f64]) -> f64 {
        let q = self.p_div;
        let (conv, div) = masses.split_at(MAX_COMPONENTS);
        let mut z = 0.0;
        if q < 1.0 {
            z += (1.0 - q) * conv[..self.conv.mixture.len()].iter().sum::<f64>();
        }
        if q > 0.0 {
            z += q * div[..self.div.mixture.len()].iter().sum::<f64>();
        }
        z
    }

    /// Fills `masses` with every component's share π_kΦ_k (converging, first half) or π_k(1 − Φ_k)
    /// (diverging, second half) of the hemisphere above (x, n), and returns
    /// Z = (1 − p_div)·Σ_conv + p_div·Σ_div (the `f64` reference).
    #[inline]
    fn hemisphere_masses(&self, x: DVec3, n: DVec3, masses: &mut [f64]) -> f64 {
        let q = self.p_div;
        let (conv, div) = masses.split_at_mut(MAX_COMPONENTS);
        if q < 1.0 {
            self.conv.mixture.half_space_masses(x, n, true, conv);
        }
        if q > 0.0 {
            self.div.mixture.half_space_masses(x, n, false, div);
        }
        self.hemisphere_total(masses)
    }

    /// The pdf from the `f64` reference kernel ([`Mixture::directional_pdf`]), which the renderer's
    /// `f32` kernel behind [`GuidingDistribution::pdf`] approximates to about 1e-6 relative. For tests
    /// and tools that check the formula itself.
    pub fn pdf_f64(&self, x: Vec3, normal: Option<Vec3>, d: Vec3) -> f64 {
        if !self.is_trained() {
            return 0.0;
        }
        let xu = self.to_unit(x);
        let n = normal.and_then(|n| unit(n.as_dvec3()));
        let z = match n {
            Some(n) => self.hemisphere_masses(xu, n, &mut [0.0; 2 * MAX_COMPONENTS]),
            None => 1.0,
        };
        self.pdf_given(xu, n, d, z, |w| self.full_pdf(xu, w))
    }

    /// The pdf at `d` from unit-frame `xu`, given the hemisphere mass `z` of the unit normal `n` and the
    /// untruncated pdf `full` of a unit direction (the one computation `pdf` and `sample` share, so their
    /// values agree bit for bit).
    #[inline]
    fn pdf_given(
        &self,
        xu: DVec3,
        n: Option<DVec3>,
        d: Vec3,
        z: f64,
        full: impl Fn(DVec3) -> f64,
    ) -> f64 {
        let Some(w) = unit(d.as_dvec3()) else {
            return 0.0;
        };
        if !xu.is_finite() {
            return 0.0;
        }
        match n {
            None => full(w),
            Some(n) => {
                if !(n.dot(w) > 0.0) || !(z >= MIN_HEMISPHERE_MASS) {
                    return 0.0;
                }
                full(w) / z
            }
        }
    }

    /// Samples a unit-frame direction (not yet rounded) from `x` (unit frame) over the whole sphere, given
    /// x's kernel `terms` ([`GmmGuide::prepare_kernel`], for the x-dependent component weights).
    fn sample_sphere(&self, x: DVec3, terms: &[f32], u: [f32; 3]) -> Option<DVec3> {
        let u1 = open_unit(u[1] as f64);
        let u2 = open_unit(u[2] as f64);
        let q = self.p_div;
        let u0 = u[0] as f64;
        let diverging = u0 < q;
        let u0 = if diverging {
            u0 / q
        } else {
            (u0 - q) / (1.0 - q)
        };
        let (conv_terms, div_terms) = terms.split_at(KERNEL_TERMS_BLOCK);
        let (mixture, terms) = if diverging {
            (&self.div.mixture, div_terms)
        } else {
            (&self.conv.mixture, conv_terms)
        };
        let y = mixture.sample_point_prepared(terms, [u0.clamp(0.0, 1.0), u1, u2])?;
        Some(if diverging { x - y } else { y - x })
    }

    /// Samples a unit-frame direction (not yet rounded) from `x` (unit frame) in the hemisphere around
    /// unit `n`, given the per-component hemisphere `masses` and their total `z`
    /// ([`GmmGuide::hemisphere_masses`]).
    fn sample_hemisphere(
        &self,
        x: DVec3,
        n: DVec3,
        masses: &[f64],
        z: f64,
        u: [f32; 3],
    ) -> Option<DVec3> {
        if !(z >= MIN_HEMISPHERE_MASS) {
            return None;
        }
        let u1 = open_unit(u[1] as f64);
        let u2 = open_unit(u[2] as f64);
        let q = self.p_div;
        let (kc, kd) = (self.conv.mixture.len(), self.div.mixture.len());
        let shares = masses[..kc].iter().map(|m| (1.0 - q) * m).chain(
            masses[MAX_COMPONENTS..MAX_COMPONENTS + kd]
                .iter()
                .map(|m| q * m),
        );
        let target = u[0] as f64 * z;
        let (i, before, m) = pick_interval(shares, target)?;
        let u0 = open_unit((target - before) / m);
        Some(if i < kc {
            let g = &self.conv.mixture.components()[i];
            sample_half_space(g, x, n, true, [u0, u1, u2]) - x
        } else {
            let g = &self.div.mixture.components()[i - kc];
            x - sample_half_space(g, x, n, false, [u0, u1, u2])
        })
    }

    /// Rounds a unit-frame direction to the `f32` sample and attaches its exact pdf.
    fn finish_sample(
        &self,
        vertex: &GuideVertex,
        xu: DVec3,
        n: Option<DVec3>,
        dir: DVec3,
        z: f64,
    ) -> Option<GuideSample> {
        let direction = unit(dir)?.as_vec3().normalize_or_zero();
        if direction == Vec3::ZERO {
            return None;
        }
        // Exactly `pdf(x, normal, direction)`, reusing the hemisphere mass and the kernel terms.
        let pdf = self.pdf_given(xu, n, direction, z, |w| {
            self.full_pdf_prepared(&vertex.buffer32, w)
        }) as f32;
        (pdf > 0.0 && pdf.is_finite()).then_some(GuideSample { direction, pdf })
    }

    /// Decodes a snapshot written by [`GuidingDistribution::save`].
    pub fn load(bytes: &[u8]) -> Result<Self, String> {
        let snapshot: Snapshot =
            postcard::from_bytes(bytes).map_err(|e| format!("not a GMM guide snapshot: {e}"))?;
        check_snapshot_header(
            "GMM guide",
            snapshot.magic,
            SNAPSHOT_MAGIC,
            snapshot.version,
            SNAPSHOT_VERSION,
        )?;
        snapshot.config.validate()?;
        let aabb = Aabb3 {
            min: Vec3::from_array(snapshot.aabb_min),
            max: Vec3::from_array(snapshot.aabb_max),
        };
        if aabb.padded("GMM guide")? != aabb {
            return Err("GMM guide snapshot has a degenerate box".into());
        }
        if !(0.0..=1.0).contains(&snapshot.p_div) {
            return Err(format!(
                "GMM guide snapshot has an invalid p_div {}",
                snapshot.p_div
            ));
        }
        snapshot
            .selection
            .validate()
            .map_err(|e| format!("GMM guide snapshot: {e}"))?;
        let (center, scale) = unit_frame(aabb);
        Ok(Self {
            aabb,
            center,
            scale,
            config: snapshot.config,
            conv: snapshot.conv.into_state(snapshot.config.k_max)?,
            div: snapshot.div.into_state(snapshot.config.k_max)?,
            p_div: snapshot.p_div,
            updates: snapshot.updates,
            pending: Pending::default(),
            selection: snapshot.selection,
            reflected: ReflectedRadiance::new(unit_box(aabb, center, scale)),
            effective_rays: [0.0; 2],
            final_render: true,
        })
    }

    /// The fit's parameters for a mixture whose statistics rest on `effective_rays` rays. The two
    /// priors (the base one and the sparse-data one) add up to one conjugate prior: both pseudo-weights
    /// are shares of the same training weight, so their sum is the share and the σ² is their
    /// share-weighted mean.
    fn fit_params(&self, seed: u64, effective_rays: f64) -> FitParams {
        let c = &self.config;
        let diagonal = ((self.aabb.max - self.aabb.min).as_dvec3() / self.scale).length();
        let base_sigma = c.prior_sigma * diagonal;
        let sparse_share = if c.sparse_prior_rays > 0.0 && effective_rays > 0.0 {
            (c.sparse_prior_rays / effective_rays).min(1.0)
        } else {
            0.0
        };
        let sparse_sigma = c.sparse_prior_sigma * diagonal;
        let strength = (c.prior_strength + sparse_share).min(1.0);
        // Without the sparse prior the base one is used exactly as given (same model, bit for bit).
        let prior_sigma = if sparse_share > 0.0 {
            ((c.prior_strength * base_sigma * base_sigma
                + sparse_share * sparse_sigma * sparse_sigma)
                / (c.prior_strength + sparse_share))
                .sqrt()
        } else {
            base_sigma
        };
        FitParams {
            k_init: c.k_init,
            k_min: c.k_min,
            k_max: c.k_max,
            em_iterations: c.em_iterations,
            prior_sigma,
            prior_strength: strength,
            floor_sigma: base_sigma * 1e-2,
            weight_floor: c.weight_floor,
            split_threshold: c.split_threshold,
            merge_threshold: c.merge_threshold,
            prune_share: c.prune_share,
            seed,
        }
    }

    /// Clips one ray to the box and buffers it (thinning the buffer if it overflows).
    #[allow(clippy::too_many_arguments)]
    fn push_ray(
        &mut self,
        diverging: bool,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        c: f64,
        pdf: f64,
        expected: f64,
    ) {
        let (lo, hi) = unit_box(self.aabb, self.center, self.scale);
        let Some((t0, t1)) = clip_to_box(o, d, t_max, lo, hi) else {
            self.pending.empty += 1;
            return;
        };
        let ray = TrainingRay {
            origin: o.as_vec3().to_array(),
            direction: d.as_vec3().to_array(),
            t0: t0 as f32,
            t1: t1 as f32,
            weight: c as f32,
            pdf: pdf as f32,
            expected: expected as f32,
        };
        if !(ray.t1 > ray.t0 && ray.weight > 0.0 && ray.weight.is_finite()) {
            self.pending.empty += 1;
            return;
        }
        let max_rays = self.config.max_rays;
        let buffer = if diverging {
            &mut self.pending.div
        } else {
            &mut self.pending.conv
        };
        buffer.push(ray);
        if buffer.len() > max_rays {
            thin(buffer);
            self.pending.thinned += 1;
        }
    }
}

/// Replaces every ray's weight c by s·c^β, with s chosen so that the rays' total mass Σ c·length is
/// unchanged.
fn temper_weights(rays: &mut [TrainingRay], beta: f64) {
    reweight_keeping_mass(rays, |c| c.powf(beta));
}

/// Clamps the rays' weights at `factor`·√N·mean (Ionides' truncated importance sampling), then
/// rescales them to the total mass they had.
fn truncate_weights(rays: &mut [TrainingRay], factor: f64) {
    if rays.is_empty() {
        return;
    }
    let n = rays.len() as f64;
    let mean = rays.iter().map(|r| r.weight as f64).sum::<f64>() / n;
    let cap = factor * n.sqrt() * mean;
    if !(cap > 0.0 && cap.is_finite()) {
        return;
    }
    reweight_keeping_mass(rays, |c| c.min(cap));
}

/// Replaces every weight c by s·f(c), s chosen so that the rays' total mass is what it was.
fn reweight_keeping_mass(rays: &mut [TrainingRay], f: impl Fn(f64) -> f64) {
    let before: f64 = rays.iter().map(TrainingRay::mass).sum();
    for r in rays.iter_mut() {
        r.weight = f(r.weight as f64) as f32;
    }
    let after: f64 = rays.iter().map(TrainingRay::mass).sum();
    if after > 0.0 && before.is_finite() {
        let s = before / after;
        for r in rays.iter_mut() {
            r.weight = (r.weight as f64 * s) as f32;
        }
    }
}

/// Clamps the rays' weights at the least bound for which (Σm)²/Σm² over their masses m = c·length
/// reaches `target` (or 0.999 of the ray count, if that is smaller), then rescales them to the total
/// mass they had. The effective count grows as the bound falls, so the bound is found by bisection
/// on its logarithm.
fn clamp_to_effective_rays(rays: &mut [TrainingRay], target: f64) {
    let target = target.min(0.999 * rays.len() as f64);
    let effective = |cap: f64| {
        effective_count(
            rays.iter()
                .map(|r| (r.weight as f64).min(cap) * (r.t1 - r.t0) as f64),
        )
    };
    let max_weight = rays.iter().map(|r| r.weight as f64).fold(0.0, f64::max);
    if !(max_weight > 0.0 && max_weight.is_finite()) || effective(max_weight) >= target {
        return;
    }
    let min_weight = rays
        .iter()
        .map(|r| r.weight as f64)
        .fold(f64::INFINITY, f64::min);
    let (mut lo, mut hi) = (min_weight.ln(), max_weight.ln());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if effective(mid.exp()) >= target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let cap = lo.exp();
    reweight_keeping_mass(rays, |c| c.min(cap));
}

/// The effective number (Σm)²/Σm² of samples with masses m (0 if all are 0).
fn effective_count(masses: impl Iterator<Item = f64>) -> f64 {
    let (s, s2) = masses.fold((0.0f64, 0.0f64), |(s, s2), m| (s + m, s2 + m * m));
    if s2 > 0.0 {
        s * s / s2
    } else {
        0.0
    }
}

/// The corners of the scene box in the unit frame (`center`, `scale`) the mixtures and rays live in.
fn unit_box(aabb: Aabb3, center: DVec3, scale: f64) -> (DVec3, DVec3) {
    (
        (aabb.min.as_dvec3() - center) / scale,
        (aabb.max.as_dvec3() - center) / scale,
    )
}

/// Keeps every other ray with doubled weight: the buffer's expected total weight is unchanged.
fn thin(buffer: &mut Vec<TrainingRay>) {
    let mut keep = 0;
    for i in (0..buffer.len()).step_by(2) {
        let mut ray = buffer[i];
        ray.weight = (ray.weight * 2.0).min(f32::MAX);
        ray.expected = (ray.expected * 2.0).min(f32::MAX);
        buffer[keep] = ray;
        keep += 1;
    }
    buffer.truncate(keep);
}

/// `v` / |v| if that is a finite unit vector.
#[inline]
fn unit(v: DVec3) -> Option<DVec3> {
    let len = v.length();
    (len > 0.0 && len.is_finite()).then(|| v / len)
}

impl GuidingDistribution for GmmGuide {
    fn name(&self) -> &'static str {
        "gmm"
    }

    /// Full sphere: `u[0]` picks the mixture (diverging with probability p_div) and, rescaled, the
    /// component and then the first normal variate; `u[1]`, `u[2]` give the other two (inverse CDF).
    /// With a normal: `u[0]` picks a component among both mixtures in proportion to its mass in the
    /// hemisphere and, rescaled, the truncated normal variate along the normal.
    fn sample(&self, x: Vec3, normal: Option<Vec3>, u: [f32; 3]) -> Option<GuideSample> {
        let mut vertex = GuideVertex::default();
        self.prepare(x, normal, &mut vertex);
        self.sample_at(&vertex, u)
    }

    /// The `f32` kernel's pdf (see [`GmmGuide::pdf_f64`] for the `f64` reference).
    fn pdf(&self, x: Vec3, normal: Option<Vec3>, d: Vec3) -> f32 {
        let mut vertex = GuideVertex::default();
        self.prepare(x, normal, &mut vertex);
        self.pdf_at(&vertex, d)
    }

    /// Computes the unit-frame point, every component's kernel terms and, with a normal, every
    /// component's hemisphere mass once.
    fn prepare(&self, x: Vec3, normal: Option<Vec3>, vertex: &mut GuideVertex) {
        vertex.x = x;
        vertex.normal = normal;
        let xu = self.to_unit(x);
        vertex.scalars = [xu.x, xu.y, xu.z, 1.0];
        if !self.is_trained() || !xu.is_finite() {
            return;
        }
        let n = normal.and_then(|n| unit(n.as_dvec3()));
        vertex.scalars[3] = self.prepare_kernel(xu, n, &mut vertex.buffer32, &mut vertex.buffer);
    }

    fn sample_at(&self, vertex: &GuideVertex, u: [f32; 3]) -> Option<GuideSample> {
        if !self.is_trained() {
            return None;
        }
        let [ux, uy, uz, z] = vertex.scalars;
        let xu = DVec3::new(ux, uy, uz);
        if !xu.is_finite() {
            return None;
        }
        let n = vertex.normal.and_then(|n| unit(n.as_dvec3()));
        let dir = match n {
            None => self.sample_sphere(xu, &vertex.buffer32, u)?,
            Some(n) => self.sample_hemisphere(xu, n, &vertex.buffer, z, u)?,
        };
        self.finish_sample(vertex, xu, n, dir, z)
    }

    fn wants_empty_segments(&self) -> bool {
        self.config.compensation > 0.0
    }

    fn selection_probability(&self, x: Vec3, glossy: bool) -> Option<f32> {
        let learned = (self.config.learn_selection && self.final_render)
            .then(|| self.selection.fraction_at(x, glossy))
            .flatten();
        Some(learned.unwrap_or(self.config.guide_fraction))
    }

    fn pdf_at(&self, vertex: &GuideVertex, d: Vec3) -> f32 {
        if !self.is_trained() {
            return 0.0;
        }
        let [ux, uy, uz, z] = vertex.scalars;
        let n = vertex.normal.and_then(|n| unit(n.as_dvec3()));
        let p = self.pdf_given(DVec3::new(ux, uy, uz), n, d, z, |w| {
            self.full_pdf_prepared(&vertex.buffer32, w)
        }) as f32;
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    /// Clips and buffers the batch's rays (`docs/design/octree.md` §3.3): the segment for a non-glossy
    /// endpoint, the forward and backward half-lines for a glossy one. Segments with a non-finite or
    /// negative weight, an invalid pdf or geometry are dropped, zero weights skipped. The mixtures are
    /// untouched until `update`.
    fn record(&mut self, segments: &[TrainingSegment]) {
        if self.config.learn_selection {
            self.selection.record(segments);
        }
        for s in segments {
            self.pending.segments += 1;
            let c = s.weight as f64;
            let pdf = s.pdf as f64;
            if !c.is_finite() || c < 0.0 || !(pdf > 0.0 && pdf.is_finite()) {
                self.pending.dropped += 1;
                continue;
            }
            let o = self.to_unit(s.origin);
            let compensated = self.config.compensation > 0.0
                && !s.glossy_origin
                && s.throughput > 0.0
                && s.throughput.is_finite();
            if compensated {
                self.reflected.add(o, c / s.throughput as f64);
            }
            if c == 0.0 {
                continue;
            }
            let expected = if compensated {
                s.throughput as f64 * s.bsdf_pdf as f64 / pdf
            } else {
                0.0
            };
            let Some(d) = unit(s.direction.as_dvec3()) else {
                self.pending.dropped += 1;
                continue;
            };
            if !o.is_finite() {
                self.pending.dropped += 1;
                continue;
            }
            if s.glossy_endpoint
                && (self.config.extend_through_refraction || !s.refracting_endpoint)
            {
                self.push_ray(false, o, d, f64::INFINITY, c, pdf, expected);
                self.push_ray(true, o, -d, f64::INFINITY, c, pdf, expected);
            } else {
                let distance = s.distance as f64 / self.scale;
                if !(distance >= 0.0) {
                    self.pending.dropped += 1;
                    continue;
                }
                self.push_ray(false, o, d, distance, c, pdf, expected);
            }
        }
    }

    /// Draws points along the buffered rays (stratified uniform, or by iterative narrowing against the
    /// mixtures the rays were rendered with from iteration ⌊`narrowing_start`·N⌋), runs stepwise MAP-EM on each mixture
    /// with the decayed statistics of earlier updates (decay `config.decay`, 0.25 from narrowing), and sets
    /// p_div = W_div / (W_conv + W_div). Runs on the caller's rayon pool (`ctx.threads` is not used:
    /// the result is the same for any pool size); `ctx.final_build` changes nothing, since a mixture
    /// has no pruning build.
    fn update(&mut self, ctx: &UpdateContext) -> UpdateStats {
        let start = Instant::now();
        // The epsilon keeps ⌊(2/3)·15⌋ at 10 despite 2/3's rounding.
        let narrowing_start =
            (ctx.training_iterations as f64 * self.config.narrowing_start + 1e-9).floor() as u32;
        let narrowing_phase = ctx.iteration >= narrowing_start;
        let decay = if narrowing_phase {
            NARROWING_DECAY
        } else {
            self.config.decay
        };
        let mut pending = std::mem::take(&mut self.pending);
        if self.config.compensation > 0.0 {
            let kappa = self.config.compensation;
            for rays in [&mut pending.conv, &mut pending.div] {
                for r in rays.iter_mut() {
                    if r.expected > 0.0 {
                        let found = kappa * self.reflected.at(r.origin_f64()) * r.expected as f64;
                        r.weight = (r.weight as f64 - found).max(0.0) as f32;
                    }
                }
                rays.retain(|r| r.weight > 0.0);
            }
            self.reflected.decay(decay);
        }
        let c = &self.config;
        for rays in [&mut pending.conv, &mut pending.div] {
            if c.weight_power != 1.0 {
                temper_weights(rays, c.weight_power);
            }
            if c.min_effective_rays > 0.0 {
                clamp_to_effective_rays(rays, c.min_effective_rays);
            }
            if c.weight_truncation > 0.0 {
                truncate_weights(rays, c.weight_truncation);
            }
        }
        // Drop a mixture whose data would hold a negligible share: no fit, no pdf cost.
        let ray_mass = |rays: &[TrainingRay]| rays.iter().map(TrainingRay::mass).sum::<f64>();
        let mass_conv = decay * self.conv.weight() + ray_mass(&pending.conv);
        let mass_div = decay * self.div.weight() + ray_mass(&pending.div);
        let total_mass = mass_conv + mass_div;
        let negligible = |m: f64| total_mass > 0.0 && m < MIN_MIXTURE_SHARE * total_mass;
        let (drop_conv, drop_div) = (negligible(mass_conv), negligible(mass_div));
        if drop_conv {
            self.conv = MixtureState::default();
            pending.conv.clear();
        }
        if drop_div {
            self.div = MixtureState::default();
            pending.div.clear();
        }
        let min_per_ray = self.config.points_per_ray as usize;
        let min_points = self.config.min_points.min(self.config.max_points);
        let per_ray_for = |rays: usize| {
            min_per_ray.max((min_points / rays.max(1)).min(MAX_ADAPTIVE_POINTS_PER_RAY))
        };
        let max_points = self.config.max_points;
        let q = self.p_div;
        let seed = mix64(self.config.seed ^ mix64(ctx.iteration as u64));
        let narrow = narrowing_phase && self.config.narrowing;
        let table = |m: &Mixture, selection: f64| {
            (narrow && !m.is_empty()).then(|| NarrowingTable::new(m, selection))
        };
        let conv_table = table(&self.conv.mixture, 1.0 - q);
        let div_table = table(&self.div.mixture, q);
        let conv_sampling = conv_table
            .as_ref()
            .map_or(PointSampling::Uniform, PointSampling::Narrowing);
        let div_sampling = div_table
            .as_ref()
            .map_or(PointSampling::Uniform, PointSampling::Narrowing);
        let narrowed = conv_table.is_some() || div_table.is_some();
        let conv_points = generate_points(
            &pending.conv,
            per_ray_for(pending.conv.len()),
            max_points,
            conv_sampling,
            seed,
        );
        let div_points = generate_points(
            &pending.div,
            per_ray_for(pending.div.len()),
            max_points,
            div_sampling,
            !seed,
        );
        let points_seconds = start.elapsed().as_secs_f64();

        let fit_start = Instant::now();
        let effective = |rays: &[TrainingRay], previous: f64| {
            decay * previous + effective_count(rays.iter().map(TrainingRay::mass))
        };
        self.effective_rays = [
            effective(&pending.conv, self.effective_rays[0]),
            effective(&pending.div, self.effective_rays[1]),
        ];
        let fit_state = |state: &MixtureState, points, tag: u64, effective_rays: f64| {
            let params = self.fit_params(mix64(seed ^ tag), effective_rays);
            let (mixture, stats, report) =
                fit(&state.mixture, &state.stats, points, decay, &params);
            (MixtureState { mixture, stats }, report)
        };
        let [conv_rays, div_rays] = self.effective_rays;
        let (mut conv, conv_report) = fit_state(&self.conv, &conv_points, 1, conv_rays);
        let (mut div, div_report) = fit_state(&self.div, &div_points, 2, div_rays);
        let fit_seconds = fit_start.elapsed().as_secs_f64();
        let origins_start = Instant::now();
        if self.config.condition_on_origins {
            let params = OriginParams {
                floor: self.config.origin_floor,
                spread: self.config.origin_spread,
                min_sigma: self.config.origin_min_sigma,
                // Nine moments per component need far fewer rays than the fit's points.
                max_rays: max_points / 4,
            };
            for (state, rays) in [(&mut conv, &pending.conv), (&mut div, &pending.div)] {
                // Without rays that reach the mixture it keeps what it has (a mixture the fit left
                // unchanged keeps its origin model; a new one has none: the global weights).
                if let Some(o) = fit_origins(rays, &state.mixture, &params) {
                    let fitted = std::mem::take(&mut state.mixture);
                    state.mixture = fitted.clone().with_origins(o).unwrap_or(fitted);
                }
            }
        }
        self.conv = conv;
        self.div = div;
        let origins_seconds = origins_start.elapsed().as_secs_f64();

        let (w_conv, w_div) = (self.conv.weight(), self.div.weight());
        self.p_div = if self.conv.mixture.is_empty() {
            if self.div.mixture.is_empty() {
                0.0
            } else {
                1.0
            }
        } else if self.div.mixture.is_empty() {
            0.0
        } else if w_conv + w_div > 0.0 && (w_conv + w_div).is_finite() {
            w_div / (w_conv + w_div)
        } else {
            0.5
        };
        self.updates += 1;
        self.final_render = ctx.final_build;
        let selection = self.config.learn_selection.then(|| self.selection.update());

        let (kc, kd) = (self.conv.mixture.len(), self.div.mixture.len());
        let sum = |f: fn(&FitReport) -> u32| (f(&conv_report) + f(&div_report)) as f64;
        let mut details = vec![
            ("k".into(), (kc + kd) as f64),
            ("k_conv".into(), kc as f64),
            ("k_div".into(), kd as f64),
            ("p_div".into(), self.p_div),
            ("w_conv".into(), w_conv),
            ("w_div".into(), w_div),
            ("effective_rays_conv".into(), self.effective_rays[0]),
            ("effective_rays_div".into(), self.effective_rays[1]),
            (
                "rays".into(),
                (pending.conv.len() + pending.div.len()) as f64,
            ),
            ("rays_conv".into(), pending.conv.len() as f64),
            ("rays_div".into(), pending.div.len() as f64),
            (
                "points".into(),
                (conv_points.len() + div_points.len()) as f64,
            ),
            ("points_conv".into(), conv_points.len() as f64),
            ("points_div".into(), div_points.len() as f64),
            ("em_iterations".into(), sum(|r| r.em_iterations)),
            ("splits".into(), sum(|r| r.splits)),
            ("merges".into(), sum(|r| r.merges)),
            ("prunes".into(), sum(|r| r.prunes)),
            ("loglik_conv".into(), conv_report.log_likelihood),
            ("loglik_div".into(), div_report.log_likelihood),
            ("narrowing".into(), narrowed as u8 as f64),
            ("dropped_conv".into(), drop_conv as u8 as f64),
            ("dropped_div".into(), drop_div as u8 as f64),
            ("decay".into(), decay),
            ("segments_dropped".into(), pending.dropped as f64),
            ("rays_empty".into(), pending.empty as f64),
            ("thinning_rounds".into(), pending.thinned as f64),
            ("points_seconds".into(), points_seconds),
            ("fit_seconds".into(), fit_seconds),
            ("origins_seconds".into(), origins_seconds),
        ];
        if let Some(sel) = selection {
            details.extend([
                ("selection_segments".into(), sel.segments as f64),
                ("selection_mean".into(), sel.mean_fraction),
                ("selection_skip_share".into(), sel.skip_share),
                ("selection_coarse_share".into(), sel.coarse_share),
            ]);
        }
        UpdateStats {
            segments: pending.segments,
            model_size: (kc + kd) as u64,
            seconds: start.elapsed().as_secs_f64(),
            details,
        }
    }

    fn save(&self) -> Vec<u8> {
        let snapshot = Snapshot {
            magic: SNAPSHOT_MAGIC,
            version: SNAPSHOT_VERSION,
            aabb_min: self.aabb.min.to_array(),
            aabb_max: self.aabb.max.to_array(),
            config: self.config,
            p_div: self.p_div,
            updates: self.updates,
            conv: SavedMixture::of(&self.conv),
            div: SavedMixture::of(&self.div),
            selection: self.selection.clone(),
        };
        postcard::to_stdvec(&snapshot).expect("serialising plain data cannot fail")
    }
}

/// The versioned snapshot layout (mixtures in the unit frame).
#[derive(Serialize, Deserialize)]
struct Snapshot {
    magic: [u8; 8],
    version: u32,
    aabb_min: [f32; 3],
    aabb_max: [f32; 3],
    config: GmmConfig,
    p_div: f64,
    updates: u32,
    conv: SavedMixture,
    div: SavedMixture,
    selection: SelectionGrid,
}

/// One mixture in a snapshot, with its statistics so training can continue.
#[derive(Serialize, Deserialize)]
struct SavedMixture {
    weights: Vec<f64>,
    means: Vec<[f64; 3]>,
    covariances: Vec<[f64; 6]>,
    stats: Vec<SuffStats>,
    origins: Option<SavedOrigins>,
}

/// A mixture's origin model in a snapshot.
#[derive(Serialize, Deserialize)]
struct SavedOrigins {
    shares: Vec<f64>,
    means: Vec<[f64; 3]>,
    covariances: Vec<[f64; 6]>,
    floor: f64,
}

impl SavedMixture {
    fn of(state: &MixtureState) -> Self {
        let m = &state.mixture;
        Self {
            weights: m.weights().to_vec(),
            means: m.components().iter().map(|g| g.mean().to_array()).collect(),
            covariances: m.components().iter().map(|g| g.covariance().0).collect(),
            stats: state.stats.clone(),
            origins: m.origins().map(|o| SavedOrigins {
                shares: o.shares().to_vec(),
                means: o.gaussians().iter().map(|g| g.mean().to_array()).collect(),
                covariances: o.gaussians().iter().map(|g| g.covariance().0).collect(),
                floor: o.floor(),
            }),
        }
    }

    fn into_state(self, k_max: usize) -> Result<MixtureState, String> {
        let k = self.weights.len();
        if self.means.len() != k || self.covariances.len() != k || self.stats.len() != k {
            return Err("GMM guide snapshot has inconsistent mixture lengths".into());
        }
        if k > k_max {
            return Err(format!(
                "GMM guide snapshot mixture has {k} components, more than k_max = {k_max}"
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
        let mut mixture = Mixture::from_normalized(self.weights, components)
            .map_err(|e| format!("GMM guide snapshot: {e}"))?;
        if let Some(o) = self.origins {
            if o.means.len() != o.covariances.len() {
                return Err("GMM guide snapshot has inconsistent origin model lengths".into());
            }
            let gaussians = o
                .means
                .iter()
                .zip(&o.covariances)
                .map(|(m, c)| Gaussian3::new(DVec3::from_array(*m), Sym3(*c)))
                .collect::<Option<Vec<_>>>()
                .ok_or("GMM guide snapshot has a non-positive-definite origin Gaussian")?;
            let model = OriginModel::new(gaussians, &o.shares, o.floor)
                .map_err(|e| format!("GMM guide snapshot: {e}"))?;
            mixture = mixture
                .with_origins(model)
                .map_err(|e| format!("GMM guide snapshot: {e}"))?;
        }
        Ok(MixtureState {
            mixture,
            stats: self.stats,
        })
    }
}

/// The selection grid's parameters: the defaults, with the guide's own fraction where nothing is learned.
fn selection_config(config: &GmmConfig) -> SelectionConfig {
    let rule = if config.selection_by_share {
        SelectionRule::ContributionShare
    } else {
        SelectionRule::SecondMoment
    };
    let defaults = SelectionConfig::default();
    SelectionConfig {
        rule,
        default_fraction: config.guide_fraction,
        min_fraction: config.selection_min.min(config.guide_fraction),
        max_fraction: config.guide_fraction,
        ..defaults
    }
}

/// Centre and scale (half the largest extent) of the unit frame.
fn unit_frame(aabb: Aabb3) -> (DVec3, f64) {
    let min = aabb.min.as_dvec3();
    let max = aabb.max.as_dvec3();
    ((min + max) * 0.5, (max - min).max_element() * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rays(weights: &[f32]) -> Vec<TrainingRay> {
        weights
            .iter()
            .enumerate()
            .map(|(i, &w)| TrainingRay {
                origin: [0.0; 3],
                direction: [1.0, 0.0, 0.0],
                t0: 0.0,
                t1: 1.0 + (i % 3) as f32,
                weight: w,
                pdf: 1.0,
                expected: 0.0,
            })
            .collect()
    }

    fn effective(rays: &[TrainingRay]) -> f64 {
        effective_count(rays.iter().map(TrainingRay::mass))
    }

    fn total(rays: &[TrainingRay]) -> f64 {
        rays.iter().map(TrainingRay::mass).sum()
    }

    #[test]
    fn clamping_reaches_the_effective_ray_count_and_keeps_the_mass() {
        let mut weights = vec![1.0f32; 99];
        weights.extend([5e3, 2e3, 700.0]);
        let mut r = rays(&weights);
        let (before_mass, before_eff) = (total(&r), effective(&r));
        assert!(before_eff < 5.0, "{before_eff}");
        clamp_to_effective_rays(&mut r, 30.0);
        let after = effective(&r);
        assert!((after - 30.0).abs() < 1e-3, "{after}");
        assert!((total(&r) / before_mass - 1.0).abs() < 1e-5);
        // The light rays keep their relative weights; the heavy ones share one bound.
        assert_eq!(r[0].weight, r[1].weight);
        assert_eq!(r[99].weight, r[101].weight);
        assert!(r[99].weight > r[0].weight);
    }

    #[test]
    fn clamping_leaves_well_supported_or_single_rays_alone() {
        let weights: Vec<f32> = (0..200).map(|i| 1.0 + (i % 7) as f32).collect();
        let mut r = rays(&weights);
        let before = r.clone();
        clamp_to_effective_rays(&mut r, 30.0);
        assert_eq!(r, before);
        let mut one = rays(&[1e6]);
        clamp_to_effective_rays(&mut one, 100.0);
        assert_eq!(one, rays(&[1e6]));
    }

    #[test]
    fn clamping_few_rays_equalises_their_weights() {
        let mut r = rays(&[1e-3, 1.0, 1e4]);
        let mass = total(&r);
        clamp_to_effective_rays(&mut r, 100.0);
        assert!(r.iter().all(|r| r.weight.is_finite() && r.weight > 0.0));
        assert!((total(&r) / mass - 1.0).abs() < 1e-5);
        // At most as many effective rays as there are; the bound falls to the lightest ray.
        assert!(effective(&r) <= 3.0);
        assert!((r[1].weight / r[2].weight - 1.0).abs() < 1e-4);
    }

    #[test]
    fn tempering_takes_the_power_and_keeps_the_mass() {
        let mut r = rays(&[1.0, 4.0, 16.0]);
        let mass = total(&r);
        temper_weights(&mut r, 0.5);
        assert!((total(&r) / mass - 1.0).abs() < 1e-6);
        assert!((r[1].weight / r[0].weight - 2.0).abs() < 1e-5);
        assert!((r[2].weight / r[0].weight - 4.0).abs() < 1e-5);
    }

    #[test]
    fn truncation_clamps_at_root_n_times_the_mean() {
        let mut weights = vec![1.0f32; 99];
        weights.push(1e4);
        let mut r = rays(&weights);
        let mass = total(&r);
        // mean 100.99, √100 = 10: the bound is 1009.9, before the mass is restored.
        truncate_weights(&mut r, 1.0);
        assert!((total(&r) / mass - 1.0).abs() < 1e-5);
        assert!(
            (r[99].weight / r[0].weight - 1009.9).abs() < 0.1,
            "{}",
            r[99].weight / r[0].weight
        );
        let mut light = rays(&[1.0, 2.0, 3.0]);
        let before = light.clone();
        truncate_weights(&mut light, 1.0);
        assert_eq!(light, before);
    }
}
