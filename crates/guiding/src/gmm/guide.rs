//! [`GmmGuide`]: focal path guiding with a converging and a diverging spatial Gaussian mixture
//! (`docs/design/gmm.md`), a [`GuidingField`].
//!
//! Internally everything lives in a *unit frame*: y_u = (y − c)/h with c the box centre and h half its
//! largest extent, so the box fits in [−1, 1]³. The directional pdf is invariant under this isotropic
//! change of units (t² dt dω scales like the density's 1/h³), and the EM statistics, the prior and the
//! covariance floor get scene-independent magnitudes.
//!
//! The pieces: sampling and pdf at a shading point (`sampling.rs`), the training-sample storage
//! (`samples.rs`), the update's pipeline (`update.rs`), the snapshot (`snapshot.rs`).

use std::any::Any;

use glam::{DVec3, Vec3};

use super::em::{FitParams, SuffStats};
use super::mixture::Mixture;
use super::GmmConfig;
use crate::{
    Aabb3, GuideSample, GuidingField, SampleStorage, SamplingDistribution, TrainingSegment,
    UpdateContext, UpdateStats,
};

/// One mixture and the online statistics it was fitted from (unit frame).
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct MixtureState {
    pub mixture: Mixture,
    pub stats: Vec<SuffStats>,
}

impl MixtureState {
    /// The total weight of the statistics.
    pub fn weight(&self) -> f64 {
        self.stats.iter().map(|s| s.weight).sum()
    }
}

/// Focal path guiding with two spatial Gaussian mixtures: a direction is drawn towards a point
/// y ~ ρ_conv (probability 1 − p_div) or away from a point y ~ ρ_div (probability p_div), and its pdf
/// (1 − p_div)·p_conv(x, ω) + p_div·p_div(x, −ω) is the exact half-line integral. With a `normal` both
/// sampling and pdf are truncated to the hemisphere around it. Untrained (before the first update that
/// saw data) it samples nothing and has pdf 0.
#[derive(Clone, Debug)]
pub struct GmmGuide {
    pub(super) aabb: Aabb3,
    pub(super) center: DVec3,
    pub(super) scale: f64,
    pub(super) config: GmmConfig,
    pub(super) conv: MixtureState,
    pub(super) div: MixtureState,
    pub(super) p_div: f64,
    pub(super) updates: u32,
    /// Effective numbers of rays behind the converging and diverging statistics (decayed as they are;
    /// reported by the updates).
    pub(super) effective_rays: [f64; 2],
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
            effective_rays: [0.0; 2],
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
            if mixture.len() > config.em.k_max {
                return Err(format!(
                    "a mixture of {} components exceeds em.k_max = {}",
                    mixture.len(),
                    config.em.k_max
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

    fn world(&self, m: &Mixture) -> Mixture {
        m.untransformed(self.center, self.scale)
            .unwrap_or_else(|_| Mixture::empty())
    }

    /// A world-space point in the unit frame.
    #[inline]
    pub(super) fn to_unit(&self, x: Vec3) -> DVec3 {
        (x.as_dvec3() - self.center) / self.scale
    }

    /// The corners of the scene box in the unit frame the mixtures and rays live in.
    pub(super) fn unit_box(&self) -> (DVec3, DVec3) {
        (
            (self.aabb.min.as_dvec3() - self.center) / self.scale,
            (self.aabb.max.as_dvec3() - self.center) / self.scale,
        )
    }

    /// The fit's parameters, with the initialisation `seed`.
    pub(super) fn fit_params(&self, seed: u64) -> FitParams {
        let em = &self.config.em;
        let diagonal = ((self.aabb.max - self.aabb.min).as_dvec3() / self.scale).length();
        let prior_sigma = em.prior_sigma * diagonal;
        FitParams {
            k_init: em.k_init,
            k_min: em.k_min,
            k_max: em.k_max,
            em_iterations: em.iterations,
            prior_sigma,
            prior_strength: em.prior_strength,
            floor_sigma: prior_sigma * 1e-2,
            weight_floor: em.weight_floor,
            split_threshold: em.split_threshold,
            merge_threshold: em.merge_threshold,
            prune_share: em.prune_share,
            seed,
        }
    }
}

impl GuidingField for GmmGuide {
    fn name(&self) -> &'static str {
        "gmm"
    }

    fn aabb(&self) -> Aabb3 {
        self.aabb
    }

    #[inline]
    fn init(&self, distribution: &mut SamplingDistribution, x: Vec3, normal: Option<Vec3>) {
        self.init_distribution(distribution.gmm_mut(), x, normal);
    }

    #[inline]
    fn sample(&self, distribution: &SamplingDistribution, u: [f32; 3]) -> Option<GuideSample> {
        match distribution {
            SamplingDistribution::Gmm(d) => self.sample_distribution(d, u),
            _ => None,
        }
    }

    #[inline]
    fn pdf(&self, distribution: &SamplingDistribution, direction: Vec3) -> f32 {
        match distribution {
            SamplingDistribution::Gmm(d) => self.distribution_pdf(d, direction),
            _ => 0.0,
        }
    }

    fn new_samples(&self) -> SampleStorage {
        self.empty_samples()
    }

    /// Clips the batch's segments to training rays in the storage; the mixtures are untouched until
    /// `update`.
    fn add_samples(&self, samples: &mut SampleStorage, segments: &[TrainingSegment]) {
        self.add_to_storage(samples, segments);
    }

    /// Runs the update's pipeline (`update.rs`): draws points along the stored rays (stratified
    /// uniform, or by iterative narrowing against the mixtures the rays were rendered with once the
    /// [`crate::Schedule`] narrows), runs stepwise MAP-EM on each mixture with the decayed statistics
    /// of earlier updates, and sets p_div = W_div / (W_conv + W_div). Runs on the caller's rayon pool
    /// (`context.threads` is not used: the result is the same for any pool size); `final_build`
    /// changes nothing, since a mixture has no pruning build.
    fn update(&mut self, samples: SampleStorage, context: &UpdateContext) -> UpdateStats {
        let (rays, segments) = self.take_samples(samples);
        self.run_update(rays, segments, context)
    }

    fn updates(&self) -> u32 {
        self.updates
    }

    fn save(&self) -> Vec<u8> {
        self.snapshot()
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// Centre and scale (half the largest extent) of the unit frame.
fn unit_frame(aabb: Aabb3) -> (DVec3, f64) {
    let min = aabb.min.as_dvec3();
    let max = aabb.max.as_dvec3();
    ((min + max) * 0.5, (max - min).max_element() * 0.5)
}

/// `v` / |v| if that is a finite unit vector.
#[inline]
pub(super) fn unit(v: DVec3) -> Option<DVec3> {
    let len = v.length();
    (len > 0.0 && len.is_finite()).then(|| v / len)
}
