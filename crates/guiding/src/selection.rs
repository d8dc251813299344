//! A learned, spatially varying probability of sampling the guide rather than the BSDF.
//!
//! A fixed one-sample mixture α·p_guide + (1 − α)·p_bsdf (Rath et al.: α = 0.5) wastes half the samples
//! wherever the guide is poor (a directly lit floor, a glossy lobe the guide does not know) and half
//! wherever it is good (a point that only sees its light through a pinhole). Every guided training
//! segment was sampled with a known mixture p₀ = α₀·p_g + (1 − α₀)·p_b and carries its contribution c
//! (which holds 1/p₀), so by importance reweighting Σ c²·p₀/p_a estimates, for any other α = a, the
//! second moment the same vertices would have had with p_a = a·p_g + (1 − a)·p_b: unbiased, from data
//! the renderer records anyway (with the emission at x_{k+1} reweighted together with next-event
//! estimation, and each segment weighted by its pixel: see
//! [`TrainingSegment::second_moment_with_fraction`]). [`SelectionGrid`] accumulates these sums for a
//! few candidate values in the cells of a hierarchy of regular grids over the scene box, and per cell
//! picks the candidate with the least second moment, from the finest level that holds enough segments.
//!
//! α = 0 saves the guide's whole cost at a vertex (no hemisphere masses, no pdf), so it is chosen
//! whenever its second moment is within [`SelectionConfig::skip_margin`] of the best. The guide's pdf is
//! then unknown at those vertices, so a renderer explores: at a random [`EXPLORATION_PROBABILITY`]
//! share of them it samples with α = [`EXPLORATION_FRACTION`], and only those segments teach the cell.
//! A random per-vertex α keeps the estimator unbiased: for each α the one-sample MIS weights sum to 1.
//!
//! A second rule ([`SelectionRule::ContributionShare`]) needs first moments only. Split the directions
//! at a vertex into those the guide covers and the rest; if the integrand f·L carries a share s of its
//! integral in the first and each part is shaped like the pdf that covers it, the one-sample mixture's
//! second moment is s²/α + (1 − s)²/(1 − α), least at α = s. Each guided segment estimates s without
//! reweighting: E[c·h] / E[c] with h = p_g/(p_g + p_b) the share of its direction the guide covers
//! (c holds 1/p₀, so Σ c·h over the cell's segments estimates the integral of f·L·h). First moments
//! are far less at the mercy of a few huge samples than second ones; the chosen α is clamped to
//! [`SelectionConfig::min_fraction`, `SelectionConfig::max_fraction`]. The model ignores how spiky
//! each part is: where the guide-covered light is a caustic that even the guide finds rarely (the
//! shaded lights' mirrors), it chooses too little.
//!
//! The GMM guide uses it for the final render only (`GmmConfig::learn_selection`, on by default with the
//! share rule and a least fraction of 0.4; training iterations keep the fixed fraction). With the second-
//! moment rule it did not beat the fixed fraction on focal scenes at equal time
//! (docs/experiments/2026-12-01-selection-second-moment.md).

use crate::{Aabb3, TrainingSegment};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The guide fractions a cell chooses among. 0 skips the guide; the largest keeps a tenth of the samples
/// on the BSDF, which bounds every path weight by ten times the BSDF-sampling one.
pub const SELECTION_CANDIDATES: [f32; 8] = [0.0, 0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9];
const CANDIDATES: usize = SELECTION_CANDIDATES.len();

/// Share of the vertices of a cell with α = 0 that a renderer samples with [`EXPLORATION_FRACTION`]
/// instead, so that the cell keeps learning what the guide would give there.
pub const EXPLORATION_PROBABILITY: f32 = 0.125;
/// The guide fraction of exploring vertices.
pub const EXPLORATION_FRACTION: f32 = 0.5;

/// How a cell of a [`SelectionGrid`] chooses its fraction from its segments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum SelectionRule {
    /// The candidate of [`SELECTION_CANDIDATES`] with the least importance-reweighted second moment.
    SecondMoment,
    /// The share of the cell's contribution arriving from directions the guide covers (see the module
    /// documentation), clamped to [`SelectionConfig::min_fraction`, `SelectionConfig::max_fraction`].
    ContributionShare,
}

/// Parameters of a [`SelectionGrid`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SelectionConfig {
    /// How a cell chooses.
    pub rule: SelectionRule,
    /// The least fraction [`SelectionRule::ContributionShare`] chooses: some guided samples remain
    /// everywhere, so every cell keeps learning.
    pub min_fraction: f32,
    /// The largest fraction [`SelectionRule::ContributionShare`] chooses.
    pub max_fraction: f32,
    /// Levels of the grid hierarchy: level l has 2^l cells per axis (so the finest has 2^(levels−1)).
    pub levels: u32,
    /// Guided segments with a positive contribution a cell needs before its own choice is used; cells
    /// with fewer take their parent's.
    pub min_segments: f64,
    /// Factor applied to the accumulated sums at every update (older iterations had older guides).
    pub decay: f64,
    /// α = 0 is chosen if its second moment is at most (1 + margin) times the best candidate's: skipping
    /// the guide makes the vertex cheaper as well.
    pub skip_margin: f64,
    /// The fraction used where nothing has been learned yet.
    pub default_fraction: f32,
}

impl Default for SelectionConfig {
    fn default() -> Self {
        Self {
            rule: SelectionRule::SecondMoment,
            min_fraction: 0.1,
            max_fraction: 0.75,
            levels: 5,
            min_segments: 128.0,
            decay: 0.5,
            skip_margin: 0.1,
            default_fraction: 0.5,
        }
    }
}

impl SelectionConfig {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), String> {
        let fail = |what: &str| Err(format!("invalid selection config: {what} ({self:?})"));
        if !(1..=7).contains(&self.levels) {
            return fail("levels must lie in 1..=7");
        }
        if !(self.min_segments >= 1.0 && self.min_segments.is_finite()) {
            return fail("min_segments must be at least 1");
        }
        if !(0.0..=1.0).contains(&self.decay) {
            return fail("decay must lie in [0, 1]");
        }
        if !(self.skip_margin >= 0.0 && self.skip_margin.is_finite()) {
            return fail("skip_margin must be >= 0");
        }
        if !(0.0..1.0).contains(&self.default_fraction) {
            return fail("default_fraction must lie in [0, 1)");
        }
        if !(0.0 < self.min_fraction
            && self.min_fraction <= self.max_fraction
            && self.max_fraction < 1.0)
        {
            return fail("need 0 < min_fraction <= max_fraction < 1");
        }
        Ok(())
    }
}

/// Cells of all levels coarser than `level` (8⁰ + 8¹ + … + 8^(level−1)): where `level` starts in the
/// coarsest-first cell list, and for `level` = the number of levels, the list's length.
fn cells_before_level(level: u32) -> usize {
    ((1usize << (3 * level)) - 1) / 7
}

/// One cell's accumulated statistics: the number of segments and, per candidate, the summed second
/// moments (Σ c²·p₀/p_a without emission and pixel weights), or for the share rule the summed
/// pixel-weighted contributions Σ w·c and their guide-covered part Σ w·c·h.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
struct CellSums {
    count: f64,
    moments: [f64; CANDIDATES],
    contribution: f64,
    covered: f64,
}

/// What an update of a [`SelectionGrid`] chose, for a render's record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SelectionSummary {
    /// Guided segments taken since the last update.
    pub segments: u64,
    /// Mean chosen fraction over the finest cells, weighted by their accumulated segments.
    pub mean_fraction: f64,
    /// Share of the accumulated segments whose finest cell chose α = 0.
    pub skip_share: f64,
    /// Share of the accumulated segments whose finest cell had to use a coarser level's choice.
    pub coarse_share: f64,
}

/// The learned guide fraction over a scene box (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SelectionGrid {
    config: SelectionConfig,
    min: [f32; 3],
    /// Finest cells per unit length, per axis.
    cells_per_unit: [f32; 3],
    /// All levels' cells, coarsest first (level l starts at `cells_before_level(l)`).
    sums: Vec<CellSums>,
    /// The chosen fraction per finest cell; empty until an update saw data.
    table: Vec<f32>,
    /// Segments taken since the last update.
    pending: u64,
}

impl SelectionGrid {
    /// An untrained grid over `aabb` (padded as the guides pad their boxes).
    pub fn new(aabb: Aabb3, config: SelectionConfig) -> Result<Self, String> {
        config.validate()?;
        let aabb = aabb.padded("selection grid")?;
        let res = (1u32 << (config.levels - 1)) as f32;
        let extent = aabb.max - aabb.min;
        Ok(Self {
            config,
            min: aabb.min.to_array(),
            cells_per_unit: (Vec3::splat(res) / extent).to_array(),
            sums: vec![CellSums::default(); cells_before_level(config.levels)],
            table: Vec::new(),
            pending: 0,
        })
    }

    /// The parameters.
    pub fn config(&self) -> SelectionConfig {
        self.config
    }

    /// True once an update has chosen fractions.
    pub fn is_trained(&self) -> bool {
        !self.table.is_empty()
    }

    /// Cells per axis of the finest level.
    fn finest_resolution(&self) -> u32 {
        1 << (self.config.levels - 1)
    }

    /// The finest cell's integer coordinates holding `x` (clamped into the box).
    #[inline]
    fn finest_cell(&self, x: Vec3) -> [u32; 3] {
        let res = self.finest_resolution();
        let rel = (x - Vec3::from_array(self.min)) * Vec3::from_array(self.cells_per_unit);
        // `as` saturates NaN to 0, so a non-finite point lands in a valid cell.
        std::array::from_fn(|a| (rel[a].max(0.0) as u32).min(res - 1))
    }

    /// Index into `sums` of the level-`level` cell holding finest cell `c`.
    #[inline]
    fn cell_index(&self, c: [u32; 3], level: u32) -> usize {
        let shift = self.config.levels - 1 - level;
        let r = 1usize << level;
        let offset = cells_before_level(level);
        let (i, j, k) = (
            (c[0] >> shift) as usize,
            (c[1] >> shift) as usize,
            (c[2] >> shift) as usize,
        );
        offset + (k * r + j) * r + i
    }

    /// The learned probability of sampling the guide at `x`; `None` before the first update with data,
    /// and under the share rule at a `glossy` vertex (which does not teach it either: see `record`).
    #[inline]
    pub fn fraction_at(&self, x: Vec3, glossy: bool) -> Option<f32> {
        if self.table.is_empty() || (glossy && self.config.rule == SelectionRule::ContributionShare)
        {
            return None;
        }
        let res = self.finest_resolution() as usize;
        let [i, j, k] = self.finest_cell(x).map(|v| v as usize);
        Some(self.table[(k * res + j) * res + i])
    }

    /// Takes a batch of training segments. Only guided ones (`guide_fraction` > 0) with a positive
    /// contribution and valid pdfs teach it: they alone know the guide's pdf of their direction.
    pub fn record(&mut self, segments: &[TrainingSegment]) {
        for s in segments {
            if !(s.guide_fraction > 0.0 && s.weight > 0.0 && s.origin.is_finite()) {
                continue;
            }
            if self.config.rule == SelectionRule::ContributionShare {
                if s.glossy_origin {
                    continue;
                }
                let (pg, pb) = (s.guide_pdf as f64, s.bsdf_pdf as f64);
                let w = s.weight as f64 * s.pixel_weight as f64;
                let valid = pg >= 0.0 && pb >= 0.0 && pg + pb > 0.0 && (pg + pb).is_finite();
                if !(valid && w.is_finite()) {
                    continue;
                }
                let covered = w * pg / (pg + pb);
                self.add(s.origin, |sums| {
                    sums.contribution += w;
                    sums.covered += covered;
                });
                continue;
            }
            let mut terms = [0.0f64; CANDIDATES];
            let mut valid = true;
            for (t, &a) in terms.iter_mut().zip(&SELECTION_CANDIDATES) {
                match s.second_moment_with_fraction(a) {
                    Some(m) => *t = m,
                    None => valid = false,
                }
            }
            if !valid {
                continue;
            }
            if !terms.iter().any(|t| t.is_finite()) {
                continue;
            }
            self.add(s.origin, |sums| {
                for (m, t) in sums.moments.iter_mut().zip(&terms) {
                    *m += t;
                }
            });
        }
    }

    /// Counts one segment at `origin` in its cell of every level and adds its terms there.
    fn add(&mut self, origin: Vec3, mut terms: impl FnMut(&mut CellSums)) {
        self.pending += 1;
        let cell = self.finest_cell(origin);
        for level in 0..self.config.levels {
            let idx = self.cell_index(cell, level);
            let sums = &mut self.sums[idx];
            sums.count += 1.0;
            terms(sums);
        }
    }

    /// The cell's fraction: by the share rule, or the candidate with the least second moment in `sums`
    /// (α = 0 within the skip margin).
    fn choose(&self, sums: &CellSums) -> f32 {
        if self.config.rule == SelectionRule::ContributionShare {
            let share = sums.covered / sums.contribution;
            return if share.is_finite() {
                (share as f32).clamp(self.config.min_fraction, self.config.max_fraction)
            } else {
                self.config.default_fraction
            };
        }
        let m = &sums.moments;
        let best = (1..CANDIDATES)
            .filter(|&i| m[i].is_finite())
            .min_by(|&a, &b| m[a].total_cmp(&m[b]));
        match best {
            None => {
                if m[0].is_finite() {
                    0.0
                } else {
                    self.config.default_fraction
                }
            }
            Some(b) if m[0] <= (1.0 + self.config.skip_margin) * m[b] => 0.0,
            Some(b) => SELECTION_CANDIDATES[b],
        }
    }

    /// Chooses every finest cell's fraction from the sums so far, then decays the sums so that the
    /// next iteration's segments count more. Deterministic: the sums are added in batch order.
    pub fn update(&mut self) -> SelectionSummary {
        let res = self.finest_resolution();
        let levels = self.config.levels;
        let mut table = Vec::with_capacity((res * res * res) as usize);
        let (mut total, mut weighted, mut skipped, mut coarse) = (0.0, 0.0, 0.0, 0.0);
        let any = self.sums[0].count > 0.0;
        for k in 0..res {
            for j in 0..res {
                for i in 0..res {
                    let c = [i, j, k];
                    let own = self.sums[self.cell_index(c, levels - 1)].count;
                    let level = (0..levels).rev().find(|&l| {
                        self.sums[self.cell_index(c, l)].count >= self.config.min_segments
                    });
                    let alpha = match level {
                        Some(l) => self.choose(&self.sums[self.cell_index(c, l)]),
                        None => self.config.default_fraction,
                    };
                    total += own;
                    weighted += own * alpha as f64;
                    if alpha == 0.0 {
                        skipped += own;
                    }
                    if level != Some(levels - 1) {
                        coarse += own;
                    }
                    table.push(alpha);
                }
            }
        }
        if any {
            self.table = table;
        }
        for s in &mut self.sums {
            s.count *= self.config.decay;
            s.contribution *= self.config.decay;
            s.covered *= self.config.decay;
            for m in &mut s.moments {
                *m *= self.config.decay;
            }
        }
        let share = |v: f64| if total > 0.0 { v / total } else { 0.0 };
        let summary = SelectionSummary {
            segments: self.pending,
            mean_fraction: if total > 0.0 {
                weighted / total
            } else {
                self.config.default_fraction as f64
            },
            skip_share: share(skipped),
            coarse_share: share(coarse),
        };
        self.pending = 0;
        summary
    }

    /// Checks a decoded grid's consistency (lengths, finite values, fractions among the candidates).
    pub fn validate(&self) -> Result<(), String> {
        self.config.validate()?;
        let res = self.finest_resolution() as usize;
        if self.sums.len() != cells_before_level(self.config.levels)
            || !(self.table.is_empty() || self.table.len() == res * res * res)
        {
            return Err("selection grid has inconsistent lengths".into());
        }
        let finite = self
            .min
            .iter()
            .chain(&self.cells_per_unit)
            .all(|v| v.is_finite())
            && self.cells_per_unit.iter().all(|&v| v > 0.0);
        if !finite {
            return Err("selection grid has a degenerate box".into());
        }
        if !self.table.iter().all(|a| (0.0..1.0).contains(a)) {
            return Err("selection grid holds a fraction outside [0, 1)".into());
        }
        if !self.sums.iter().all(|s| {
            s.count >= 0.0
                && s.moments.iter().all(|m| *m >= 0.0)
                && s.contribution >= 0.0
                && s.covered >= 0.0
        }) {
            return Err("selection grid holds negative sums".into());
        }
        Ok(())
    }
}
