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
//! [`SelectionLayer`] puts the grid over any guide: it asks the renderer for the guide's fixed fraction
//! while training and for the learned one in the final render. The GMM guide's configuration turns it
//! on (`selection.learn`, with the share rule and a least fraction of 0.4); the octree's leaves the
//! renderer's fixed fraction (Rath et al.'s 0.5) until the layer is measured on it. With the second-
//! moment rule it did not beat the fixed fraction on focal scenes at equal time
//! (docs/experiments/2026-12-01-selection-second-moment.md).

mod grid;
mod layer;

pub use grid::{
    SelectionConfig, SelectionGrid, SelectionRule, SelectionSamples, SelectionSummary,
    EXPLORATION_FRACTION, EXPLORATION_PROBABILITY, SELECTION_CANDIDATES,
};
pub use layer::GUIDE_SNAPSHOT_MAGIC;
pub use layer::{SelectionLayer, SelectionLayerConfig};
