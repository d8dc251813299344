//! [`SelectionLayer`]: the learned selection probability as a layer over any guide.

use std::any::Any;
use std::time::Instant;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::grid::{SavedGrid, SelectionSamples};
use super::{SelectionConfig, SelectionGrid, SelectionRule};
use crate::snapshot::{decode, encode};
use crate::{
    Aabb3, GuideSample, GuidingField, SampleStorage, SamplingDistribution, TrainingSegment,
    UpdateContext, UpdateStats,
};

/// Magic prefix of [`SelectionLayer::save`] snapshots ("focal guide": a guide with its layer).
pub const GUIDE_SNAPSHOT_MAGIC: [u8; 8] = *b"FOCALGDE";
/// Version of the layer's snapshot layout.
const SNAPSHOT_VERSION: u32 = 1;

/// How a guide chooses between itself and the BSDF at a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SelectionLayerConfig {
    /// The probability of sampling the guide rather than the BSDF that the guide asks a renderer for
    /// (a fraction the user gives the renderer wins); `None` leaves the renderer's own fraction (the
    /// octree: Rath et al.'s 0.5). The GMM asks for 0.75: its exact, hemisphere-truncated pdf can be
    /// leaned on harder (`docs/experiments/`).
    pub guide_fraction: Option<f32>,
    /// Learn the fraction per region of space ([`SelectionGrid`]) for the final render (training
    /// iterations keep `guide_fraction`, which must be given).
    pub learn: bool,
    /// Choose each region's fraction as the share of its contribution that arrives from directions
    /// the guide covers ([`SelectionRule::ContributionShare`]), between `min` and `guide_fraction`,
    /// rather than by least second moment; glossy vertices keep `guide_fraction` and do not teach the
    /// grid (on a rough glass the share is near 0, but the fixed fraction wins).
    pub by_share: bool,
    /// The least fraction the share rule chooses (at most `guide_fraction`). 0.4 rather than 0.1:
    /// lower floors starved diffuse receivers that see their light through a caustic the guide covers
    /// but still finds rarely.
    pub min: f32,
}

impl Default for SelectionLayerConfig {
    /// The GMM guide's: 0.75, learned per region by the share rule for the final render.
    fn default() -> Self {
        Self {
            guide_fraction: Some(0.75),
            learn: true,
            by_share: true,
            min: 0.4,
        }
    }
}

impl SelectionLayerConfig {
    /// The layer that leaves the renderer's fixed fraction everywhere (the octree's default).
    pub fn renderers_fraction() -> Self {
        Self {
            guide_fraction: None,
            learn: false,
            ..Self::default()
        }
    }

    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), String> {
        if let Some(f) = self.guide_fraction {
            if !(f > 0.0 && f < 1.0) {
                return Err(format!(
                    "selection: guide_fraction must lie in (0, 1), got {f}"
                ));
            }
        } else if self.learn {
            return Err("selection: learning the fraction needs a guide_fraction".into());
        }
        if !(self.min > 0.0 && self.min < 1.0) {
            return Err(format!(
                "selection: min must lie in (0, 1), got {}",
                self.min
            ));
        }
        Ok(())
    }

    /// The grid's parameters: the defaults, with the guide's own fraction where nothing is learned.
    fn grid_config(&self) -> Option<SelectionConfig> {
        let fraction = self.guide_fraction.filter(|_| self.learn)?;
        let rule = if self.by_share {
            SelectionRule::ContributionShare
        } else {
            SelectionRule::SecondMoment
        };
        Some(SelectionConfig {
            rule,
            default_fraction: fraction,
            min_fraction: self.min.min(fraction),
            max_fraction: fraction,
            ..SelectionConfig::default()
        })
    }
}

/// A guide with the probability of sampling it rather than the BSDF: a fixed fraction while training,
/// and in the final render, with `learn`, one learned per region of space from the training segments
/// ([`SelectionGrid`]). It passes sampling, pdfs and the guide's own training through unchanged.
#[derive(Clone, Debug)]
pub struct SelectionLayer<F> {
    field: F,
    config: SelectionLayerConfig,
    grid: Option<SelectionGrid>,
    /// The last update prepared the final render (or the guide was loaded to render with): the
    /// learned fraction applies.
    final_render: bool,
}

/// The layer's training-sample storage: the guide's own and the grid's part.
struct LayerSamples {
    field: SampleStorage,
    selection: Option<SelectionSamples>,
}

/// The layer's snapshot: the guide's own snapshot and the grid's model.
#[derive(Serialize, Deserialize)]
struct LayerSnapshot {
    field: Vec<u8>,
    grid: Option<SavedGrid>,
}

impl<F: GuidingField + 'static> SelectionLayer<F> {
    /// `field` with a layer of `config` (a learning grid over the field's box).
    pub fn new(field: F, config: SelectionLayerConfig) -> Result<Self, String> {
        config.validate()?;
        let grid = match config.grid_config() {
            Some(c) => Some(SelectionGrid::new(field.aabb(), c)?),
            None => None,
        };
        Ok(Self {
            field,
            config,
            grid,
            final_render: false,
        })
    }

    /// The guide under the layer.
    pub fn field(&self) -> &F {
        &self.field
    }

    /// The guide under the layer, to change (an update of it alone leaves the grid as it was).
    pub fn field_mut(&mut self) -> &mut F {
        &mut self.field
    }

    /// The layer's parameters.
    pub fn config(&self) -> SelectionLayerConfig {
        self.config
    }

    /// The learning grid, with `learn`.
    pub fn grid(&self) -> Option<&SelectionGrid> {
        self.grid.as_ref()
    }

    /// Decodes a snapshot written by [`SelectionLayer::save`], with `config` and the guide's own
    /// snapshot decoded by `load_field`. A loaded layer renders with its learned fraction (if it has
    /// one and `config` learns). Errors name what is wrong, never panic.
    pub fn load(
        bytes: &[u8],
        config: SelectionLayerConfig,
        load_field: impl FnOnce(&[u8]) -> Result<F, String>,
    ) -> Result<Self, String> {
        config.validate()?;
        let snapshot: LayerSnapshot =
            decode("guide", GUIDE_SNAPSHOT_MAGIC, SNAPSHOT_VERSION, bytes)?;
        let field = load_field(&snapshot.field)?;
        let grid = match (config.grid_config(), snapshot.grid) {
            (Some(c), Some(saved)) => Some(
                SelectionGrid::from_saved(c, saved).map_err(|e| format!("guide snapshot: {e}"))?,
            ),
            (Some(c), None) => Some(SelectionGrid::new(field.aabb(), c)?),
            (None, _) => None,
        };
        Ok(Self {
            field,
            config,
            grid,
            final_render: true,
        })
    }
}

impl<F: GuidingField + 'static> GuidingField for SelectionLayer<F> {
    fn name(&self) -> &'static str {
        self.field.name()
    }

    fn aabb(&self) -> Aabb3 {
        self.field.aabb()
    }

    #[inline]
    fn init(&self, distribution: &mut SamplingDistribution, x: Vec3, normal: Option<Vec3>) {
        self.field.init(distribution, x, normal)
    }

    #[inline]
    fn sample(&self, distribution: &SamplingDistribution, u: [f32; 3]) -> Option<GuideSample> {
        self.field.sample(distribution, u)
    }

    #[inline]
    fn pdf(&self, distribution: &SamplingDistribution, direction: Vec3) -> f32 {
        self.field.pdf(distribution, direction)
    }

    /// The learned fraction at `x` in the final render where the grid has one, else the fixed
    /// `guide_fraction`; `None` (the renderer's own) without a fixed one.
    #[inline]
    fn selection_probability(&self, x: Vec3, glossy: bool) -> Option<f32> {
        let fixed = self.config.guide_fraction?;
        let learned = match (&self.grid, self.final_render) {
            (Some(grid), true) => grid.fraction_at(x, glossy),
            _ => None,
        };
        Some(learned.unwrap_or(fixed))
    }

    fn new_samples(&self) -> SampleStorage {
        let samples = LayerSamples {
            field: self.field.new_samples(),
            selection: self.grid.as_ref().map(SelectionGrid::new_samples),
        };
        SampleStorage::new(self.field.name(), self.field.updates(), samples)
    }

    fn add_samples(&self, samples: &mut SampleStorage, segments: &[TrainingSegment]) {
        let parts: &mut LayerSamples = samples.data_mut(self.field.updates(), segments.len());
        if let (Some(grid), Some(selection)) = (&self.grid, &mut parts.selection) {
            grid.record(selection, segments);
        }
        self.field.add_samples(&mut parts.field, segments);
    }

    /// Updates the guide, then chooses the grid's fractions from this iteration's sums; the learned
    /// fractions apply once the update prepares the final render.
    fn update(&mut self, samples: SampleStorage, context: &UpdateContext) -> UpdateStats {
        let start = Instant::now();
        let (parts, _) = samples.into_data::<LayerSamples>(self.field.updates());
        let mut stats = self.field.update(parts.field, context);
        self.final_render = context.final_build;
        if let (Some(grid), Some(selection)) = (&mut self.grid, parts.selection) {
            let sel = grid.update(selection);
            stats.details.extend([
                ("selection_segments".into(), sel.segments as f64),
                ("selection_mean".into(), sel.mean_fraction),
                ("selection_skip_share".into(), sel.skip_share),
                ("selection_coarse_share".into(), sel.coarse_share),
            ]);
        }
        stats.seconds = start.elapsed().as_secs_f64();
        stats
    }

    fn updates(&self) -> u32 {
        self.field.updates()
    }

    fn save(&self) -> Vec<u8> {
        let snapshot = LayerSnapshot {
            field: self.field.save(),
            grid: self.grid.as_ref().map(|g| g.saved().clone()),
        };
        encode(GUIDE_SNAPSHOT_MAGIC, SNAPSHOT_VERSION, &snapshot)
    }

    fn as_any(&self) -> &dyn Any {
        self.field.as_any()
    }
}
