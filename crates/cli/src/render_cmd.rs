//! `focal render`.

use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::load::{load_scene, make_integrator};
use focal_render::render::{render, RenderSettings};
use focal_render::sampler::SamplerKind;
use focal_render::scene::{BuildOptions, Strictness};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;

/// Arguments of `focal render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scene file (Mitsuba 0.6 or 3 XML).
    pub scene: PathBuf,
    /// Output EXR path (default: the scene's name with .exr, in the current directory).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Samples per pixel (default: the scene's sampler sample_count). With --time: an upper bound.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Time budget in seconds (renders whole passes until the budget is used).
    #[arg(long)]
    pub time: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Random seed (the same seed and spp give a bit-identical image for any thread count).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Scene parameter override, `name=value` (repeatable), as Mitsuba's -D.
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
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
}

/// Parses `-D name=value` arguments.
pub fn parse_defines(defines: &[String]) -> Result<Vec<(String, String)>> {
    defines
        .iter()
        .map(|d| match d.split_once('=') {
            Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
            _ => bail!("-D expects NAME=VALUE, got '{d}'"),
        })
        .collect()
}

/// Parses a sampler name.
pub fn parse_sampler(s: &str) -> Result<SamplerKind> {
    match s {
        "independent" => Ok(SamplerKind::Independent),
        "sobol" | "stratified" => Ok(SamplerKind::Sobol),
        _ => bail!("unknown sampler '{s}' (independent or sobol)"),
    }
}

/// Runs `focal render`.
pub fn run(a: RenderArgs) -> Result<()> {
    let params = parse_defines(&a.defines)?;
    let opts = BuildOptions {
        integrator_override: a.integrator.clone(),
        strictness: if a.lenient {
            Strictness::Lenient
        } else {
            Strictness::Strict
        },
    };
    let load_start = std::time::Instant::now();
    let loaded = load_scene(&a.scene, &params, &opts)?;
    let load_seconds = load_start.elapsed().as_secs_f64();
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(t) = a.time {
        if !(t > 0.0) {
            bail!("--time must be positive");
        }
    }
    let spp = match (a.spp, a.time) {
        (Some(s), _) => s,
        (None, Some(_)) => u32::MAX,
        (None, None) => loaded.sampler.spp,
    };
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    let sampler = match &a.sampler {
        Some(s) => parse_sampler(s)?,
        None => loaded.sampler.kind,
    };
    let settings = RenderSettings {
        spp,
        time_limit: a.time.map(Duration::from_secs_f64),
        seed: a.seed,
        threads: a.threads,
        aovs: a.aovs,
        sampler,
    };
    let output = a.output.clone().unwrap_or_else(|| {
        PathBuf::from(a.scene.file_stem().unwrap_or_default()).with_extension("exr")
    });
    let integrator = make_integrator(&loaded.integrator);

    let bar = if a.quiet {
        ProgressBar::hidden()
    } else if a.time.is_some() {
        let b = ProgressBar::new((a.time.unwrap() * 1000.0) as u64);
        b.set_style(
            ProgressStyle::with_template("{bar:40.cyan/blue} {elapsed_precise}/{msg} {prefix}")
                .expect("valid template"),
        );
        b.set_message(format!("{:.1}s", a.time.unwrap()));
        b
    } else {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template(
                "{bar:40.cyan/blue} {percent:>3}% {human_pos}/{human_len} samples  {elapsed_precise} ETA {eta_precise}  {prefix}",
            )
            .expect("valid template"),
        );
        b
    };
    let progress = |p: focal_render::render::Progress| {
        if a.time.is_some() {
            bar.set_position(p.elapsed.as_millis() as u64);
        } else {
            bar.set_length(p.samples_total);
            bar.set_position(p.samples_done);
        }
        let rate = p.samples_done as f64 / p.elapsed.as_secs_f64().max(1e-9) / 1e6;
        bar.set_prefix(format!("{rate:.2} Msamples/s"));
    };
    let out = render(
        &loaded.scene,
        &loaded.camera,
        &loaded.film,
        integrator.as_ref(),
        &settings,
        &progress,
    );
    bar.finish_and_clear();

    let mut image = out.image;
    image.sanitize();
    image
        .write_exr(&output)
        .with_context(|| format!("writing {}", output.display()))?;
    let png = if a.png {
        let p = output.with_extension("png");
        image
            .write_png(&p, a.exposure)
            .with_context(|| format!("writing {}", p.display()))?;
        Some(p)
    } else {
        None
    };
    let mean = image.mean_rgb();
    let sidecar = serde_json::json!({
        "focal_version": env!("CARGO_PKG_VERSION"),
        "scene": a.scene.display().to_string(),
        "output": output.display().to_string(),
        "png": png.as_ref().map(|p| p.display().to_string()),
        "width": loaded.film.crop_size.x,
        "height": loaded.film.crop_size.y,
        "integrator": loaded.integrator,
        "sampler": format!("{:?}", sampler),
        "seed": a.seed,
        "defines": params,
        "requested_spp": a.spp,
        "time_budget_s": a.time,
        "spp": out.stats.spp,
        "load_s": load_seconds,
        "render_s": out.stats.seconds,
        "samples_per_s": out.stats.samples_per_second,
        "passes": out.stats.passes,
        "threads": out.stats.threads,
        "rejected_samples": out.stats.rejected_samples,
        "mean_rgb": mean,
        "warnings": loaded.warnings,
    });
    let json_path = output.with_extension("json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("writing {}", json_path.display()))?;
    eprintln!(
        "{}: {} spp in {:.2} s ({:.2} Msamples/s), mean RGB [{:.5}, {:.5}, {:.5}]",
        output.display(),
        out.stats.spp,
        out.stats.seconds,
        out.stats.samples_per_second / 1e6,
        mean[0],
        mean[1],
        mean[2]
    );
    Ok(())
}
