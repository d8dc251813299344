//! The command line of `focal compare`.

use clap::Args;
use std::path::PathBuf;

/// Arguments of `focal compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Comma-separated methods: pt (the path tracer), none (the guided path tracer without a guide),
    /// octree, gmm.
    #[arg(long, default_value = "pt,octree,gmm")]
    pub methods: String,
    /// Equal-time budget per render in seconds, training included.
    #[arg(long)]
    pub time: Option<f64>,
    /// Equal-sample budget per render (spp), training included.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Independent seeds per method.
    #[arg(long, default_value_t = 1)]
    pub seeds: u64,
    /// The reference image (EXR).
    #[arg(long)]
    pub reference: PathBuf,
    /// A second reference, rendered independently of the first (another method or seed): every run's
    /// relMSE is then also estimated against the true image, with both references' noise taken out
    /// (see `focal metrics --second-reference`). Use it when the reference is itself noisy, as long
    /// renders of focal scenes often are.
    #[arg(long, value_name = "EXR")]
    pub second_reference: Option<PathBuf>,
    /// Output folder (made if missing).
    #[arg(
        short = 'o',
        long = "output",
        visible_alias = "out",
        value_name = "DIR",
        default_value = "compare"
    )]
    pub out: PathBuf,
    /// Scene parameter override, `name=value` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Film size of the runs, `W` or `WxH` (with only W, the film's aspect ratio is kept); the
    /// references must have it.
    #[arg(long, value_name = "W[xH]")]
    pub res: Option<String>,
    /// Worker threads: 0 (the default) means one per core; at most 4 per core.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// ε of relMSE.
    #[arg(long, default_value_t = focal_render::eval::metrics::DEFAULT_REL_EPSILON)]
    pub epsilon: f64,
    /// Fraction of the largest per-pixel errors dropped (e.g. 0.001).
    #[arg(long, default_value_t = 0.0)]
    pub outliers: f64,
    /// Exposure (stops) of the PNGs.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Training iterations of guided methods.
    #[arg(long)]
    pub iterations: Option<u32>,
    /// Share of a time budget spent training.
    #[arg(long)]
    pub train_fraction: Option<f64>,
    /// How guided iterations are combined: variance or last.
    #[arg(long, default_value = "variance")]
    pub combine: String,
    /// Points on the convergence curves: independent runs at the budget / 2^k for k = K−1 … 0 (the last
    /// is the main run); 1 draws no curve beyond the main runs.
    #[arg(long, default_value_t = 4)]
    pub curve_points: u32,
}
