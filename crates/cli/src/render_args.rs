//! The command line of `focal render`.

use crate::guiding_args::GuidingArgs;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `focal render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// The scene file (Mitsuba 0.6 or 3 XML).
    pub scene: PathBuf,
    /// Output EXR path (default: the scene's name with .exr, in the current directory). The JSON
    /// sidecar and, with --png, the PNG are written beside it.
    #[arg(short, long, visible_alias = "out", value_name = "EXR")]
    pub output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's sampler sample_count). With --time: an upper bound.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Time budget in seconds (renders whole passes until the budget is used).
    #[arg(long)]
    pub time: Option<f64>,
    /// Worker threads: 0 (the default) means one per core; at most 4 per core.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Random seed (the same seed and spp give a bit-identical image for any thread count).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Scene parameter override, `name=value` (repeatable), as Mitsuba's -D.
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Film size, `W` or `WxH`, for any scene (with only W, the film's aspect ratio is kept).
    #[arg(long, value_name = "W[xH]")]
    pub res: Option<String>,
    /// Render shard I of N of one render (I counts from 0): the N shards draw disjoint samples, and
    /// `focal merge` of all N gives the image of one render with N times --spp. Needs --spp, and for a
    /// guided render a trained guide (--load-guide). See docs/sharding.md.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Also write a tonemapped sRGB PNG beside the EXR.
    #[arg(long)]
    pub png: bool,
    /// Exposure (stops) for the PNG.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Add albedo, normal and depth layers to the EXR.
    #[arg(long)]
    pub aovs: bool,
    /// Override the scene's integrator plugin (e.g. `path`).
    #[arg(long)]
    pub integrator: Option<String>,
    /// Override the sampler: independent or sobol.
    #[arg(long)]
    pub sampler: Option<String>,
    /// Treat unsupported plugins as warnings with documented fallbacks instead of errors.
    #[arg(long)]
    pub lenient: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    #[command(flatten)]
    pub guiding: GuidingArgs,
}
