//! `focal reference`: a long, resumable render for use as a reference, with its per-pixel variance of
//! the mean: unguided, or guided by a saved guide (`--load-guide`), so that a scene's truth can come from
//! two independent references made by different methods.

use crate::guiding_args::load_guide_for;
use crate::input_checks;
use crate::interrupt;
use crate::render_cmd::{parse_defines, parse_res, parse_sampler};
use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::integrator::{GuidedPathIntegrator, GuidedSettings, Integrator, PathIntegrator};
use focal_render::load::load_scene;
use focal_render::render::memory::plain_render_bytes;
use focal_render::render::reference::{
    checkpoint_path, fnv1a64, render_reference, ReferenceOutcome, ReferenceSettings,
};
use focal_render::render::RenderSettings;
use focal_render::scene::{BuildOptions, IntegratorSpec};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;

/// The default seed of reference renders.
pub const REFERENCE_SEED: u64 = 0x5eed_0000_0000_0001;

/// Arguments of `focal reference`.
#[derive(Args, Debug, Clone)]
pub struct ReferenceArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Total samples per pixel.
    #[arg(long)]
    pub spp: u32,
    /// Output EXR (RGB plus a `variance` layer: per-pixel variance of the mean). The checkpoint is
    /// `OUT.checkpoint` beside it; run the same command again to resume.
    #[arg(
        short,
        long,
        visible_alias = "out",
        value_name = "EXR",
        default_value = "reference.exr"
    )]
    pub output: PathBuf,
    /// Samples per pixel of each pass (the variance is estimated from the passes; at least two needed).
    #[arg(long, default_value_t = 16)]
    pub pass_spp: u32,
    /// Seconds between checkpoint writes (0: after every pass).
    #[arg(long, default_value_t = 10.0)]
    pub checkpoint_every: f64,
    /// Stop after this many passes of this run (leaves a checkpoint; for testing and for splitting
    /// a render into time slots).
    #[arg(long)]
    pub stop_after_passes: Option<u32>,
    /// Random seed. The default lies far from the seeds `focal render` and `compare` use (0, 1, ...),
    /// so the reference's noise is independent of the renders it judges (a shared seed shares samples).
    #[arg(long, default_value_t = REFERENCE_SEED)]
    pub seed: u64,
    /// Worker threads: 0 (the default) means one per core; at most 4 per core (the result does not
    /// depend on it).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Scene parameter override, `name=value` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Film size, `W` or `WxH` (with only W, the film's aspect ratio is kept).
    #[arg(long, value_name = "W[xH]")]
    pub res: Option<String>,
    /// Override the sampler: independent or sobol.
    #[arg(long)]
    pub sampler: Option<String>,
    /// Override the scene's integrator plugin (e.g. `path` for scenes written for another renderer's
    /// integrator); its path settings (depth, emitter visibility) are used.
    #[arg(long)]
    pub integrator: Option<String>,
    /// Render with this trained guide (saved by `focal render --save-guide`) and the guided path tracer's
    /// default settings, instead of the plain path tracer. The guide is not trained further, so the
    /// reference stays unbiased; the guide file is part of the checkpoint's key.
    #[arg(long, value_name = "GUIDE")]
    pub load_guide: Option<PathBuf>,
    /// Use a --load-guide guide even if it was trained on another scene.
    #[arg(long, requires = "load_guide")]
    pub force_guide: bool,
    /// Also write a tonemapped PNG.
    #[arg(long)]
    pub png: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Runs `focal reference`.
pub fn run(a: ReferenceArgs) -> Result<()> {
    if a.spp == 0 || a.pass_spp == 0 {
        bail!("--spp and --pass-spp must be at least 1");
    }
    if !(a.checkpoint_every >= 0.0) || !a.checkpoint_every.is_finite() {
        bail!("--checkpoint-every must be a non-negative number of seconds");
    }
    input_checks::threads(a.threads)?;
    input_checks::output_file("-o", &a.output, "exr", "the reference")?;
    let params = parse_defines(&a.defines)?;
    let options = BuildOptions {
        integrator_override: a.integrator.clone(),
        film_size: a.res.as_deref().map(parse_res).transpose()?,
        ..BuildOptions::default()
    };
    let loaded = load_scene(&a.scene, &params, &options)?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    let sampler = match &a.sampler {
        Some(s) => parse_sampler(s)?,
        None => loaded.sampler.kind,
    };
    // Without a guide, a guided scene is rendered by the plain path tracer with its path settings.
    let path = match &loaded.integrator {
        IntegratorSpec::Path(p) => *p,
        IntegratorSpec::Guided(g) => g.settings.path,
    };
    let guide_bytes = match &a.load_guide {
        Some(p) => std::fs::read(p).with_context(|| format!("reading {}", p.display()))?,
        None => Vec::new(),
    };
    let guide = match &a.load_guide {
        Some(p) => Some(
            load_guide_for(p, &loaded.scene, &a.scene, a.force_guide)?
                .guide(&focal_render::guide::GuideParams::default())
                .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?,
        ),
        None => None,
    };
    let guided_settings = GuidedSettings {
        path,
        ..GuidedSettings::default()
    };
    let integrator: Box<dyn Integrator + '_> = match &guide {
        Some(g) => Box::new(GuidedPathIntegrator {
            settings: guided_settings,
            guide: Some(g.as_ref()),
        }),
        None => Box::new(PathIntegrator { settings: path }),
    };
    let scene_bytes =
        std::fs::read(&a.scene).with_context(|| format!("reading {}", a.scene.display()))?;
    let defines = format!("{params:?}");
    let mut shape = match &guide {
        Some(_) => format!(
            "seed={} sampler={sampler:?} pass={} guided={guided_settings:?}",
            a.seed, a.pass_spp
        ),
        None => format!(
            "seed={} sampler={sampler:?} pass={} path={path:?}",
            a.seed, a.pass_spp
        ),
    };
    if let Some(res) = &a.res {
        shape += &format!(" res={res}");
    }
    // Two films and the per-pixel sums of the passes and of their squares.
    let (fw, fh) = (loaded.film.crop_size.x, loaded.film.crop_size.y);
    let needed = 2 * plain_render_bytes(&loaded.film, false) + fw as u64 * fh as u64 * 48;
    input_checks::memory(needed, &format!("a {fw}x{fh} reference"))?;
    let key = fnv1a64(&[
        &scene_bytes,
        defines.as_bytes(),
        shape.as_bytes(),
        &guide_bytes,
    ]);
    let settings = ReferenceSettings {
        render: RenderSettings {
            spp: a.spp,
            time_limit: None,
            seed: a.seed,
            threads: a.threads,
            aovs: false,
            sampler,
            cancel: interrupt::install(),
            ..RenderSettings::default()
        },
        pass_spp: a.pass_spp,
        checkpoint_interval: Duration::from_secs_f64(a.checkpoint_every),
        stop_after_passes: a.stop_after_passes,
        key,
    };
    let checkpoint = checkpoint_path(&a.output);
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template(
                "{bar:40.cyan/blue} {percent:>3}% {human_pos}/{human_len} samples  {elapsed_precise} ETA {eta_precise}",
            )
            .expect("valid template"),
        );
        b
    };
    let progress = |p: focal_render::render::Progress| {
        bar.set_length(p.samples_total);
        bar.set_position(p.samples_done);
    };
    let outcome = render_reference(
        &loaded.scene,
        &loaded.camera,
        &loaded.film,
        integrator.as_ref(),
        &settings,
        &checkpoint,
        &progress,
    )
    .with_context(|| format!("reference render of {}", a.scene.display()))?;
    bar.finish_and_clear();
    let (image, stats, resumed) = match outcome {
        ReferenceOutcome::Stopped { spp_done } => {
            eprintln!(
                "stopped at {spp_done}/{} spp {}; checkpoint {} (run the same command to resume)",
                a.spp,
                if interrupt::interrupted() {
                    "(interrupted)"
                } else {
                    "as asked"
                },
                checkpoint.display()
            );
            return Ok(());
        }
        ReferenceOutcome::Finished {
            image,
            stats,
            resumed_from_spp,
        } => (image, stats, resumed_from_spp),
    };
    image
        .write_exr(&a.output)
        .with_context(|| format!("writing {}", a.output.display()))?;
    if a.png {
        let p = a.output.with_extension("png");
        image
            .write_png(&p, 0.0)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    let sidecar = serde_json::json!({
        "focal_version": env!("CARGO_PKG_VERSION"),
        "kind": "reference",
        "scene": a.scene.display().to_string(),
        "output": a.output.display().to_string(),
        "width": loaded.film.crop_size.x,
        "height": loaded.film.crop_size.y,
        "sampler": format!("{sampler:?}"),
        "seed": a.seed,
        "defines": params,
        "loaded_guide": a.load_guide.as_ref().map(|p| p.display().to_string()),
        "spp": stats.spp,
        "pass_spp": a.pass_spp,
        "passes": stats.passes,
        "resumed_from_spp": resumed,
        "render_s": stats.seconds,
        "samples_per_s": stats.samples_per_second,
        "rejected_samples": stats.rejected_samples,
        "mean_rgb": image.mean_rgb(),
        "variance_layer": focal_render::render::reference::VARIANCE_LAYER,
        "checkpoint_key": format!("{key:016x}"),
    });
    let json = a.output.with_extension("json");
    std::fs::write(&json, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("writing {}", json.display()))?;
    eprintln!(
        "{}: {} spp in {:.2} s over {} passes{}",
        a.output.display(),
        stats.spp,
        stats.seconds,
        stats.passes,
        if resumed > 0 {
            format!(" (resumed at {resumed} spp)")
        } else {
            String::new()
        }
    );
    Ok(())
}
