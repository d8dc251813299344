//! What `focal render` writes: the EXR, the optional PNG beside it, and the JSON sidecar that records
//! how the image was made (and whether it was interrupted).

use crate::interrupt;
use crate::render_args::RenderArgs;
use anyhow::{bail, Context, Result};
use focal_render::render::{RenderOutput, RenderSettings};
use focal_render::scene::LoadedScene;
use std::path::Path;

/// The parts of the sidecar that only some renders have.
#[derive(Default)]
pub struct RenderRecord {
    /// Guided renders: the guide and its settings.
    pub guiding: serde_json::Value,
    /// Guided renders: per-iteration statistics.
    pub iterations: serde_json::Value,
    /// Sharded renders: which shard and which samples.
    pub shard: Option<serde_json::Value>,
    /// Seconds spent loading the scene.
    pub load_seconds: f64,
}

/// Writes the image of a finished or interrupted render, its PNG (with --png) and its sidecar. An
/// interrupted render without a single finished pass writes nothing.
pub fn write_render(
    a: &RenderArgs,
    output: &Path,
    loaded: &LoadedScene,
    params: &[(String, String)],
    settings: &RenderSettings,
    out: RenderOutput,
    record: RenderRecord,
) -> Result<()> {
    let interrupted = interrupt::interrupted();
    if out.stats.spp == 0 {
        if interrupted {
            bail!("interrupted before the first pass finished: nothing was written");
        }
        bail!("the render finished no sample (nothing was written)");
    }
    let mut image = out.image;
    image.sanitize();
    image
        .write_exr(output)
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
        "sampler": format!("{:?}", settings.sampler),
        "seed": a.seed,
        "defines": params,
        "requested_spp": a.spp,
        "time_budget_s": a.time,
        "spp": out.stats.spp,
        "interrupted": interrupted,
        "shard": record.shard,
        "load_s": record.load_seconds,
        "render_s": out.stats.seconds,
        "samples_per_s": out.stats.samples_per_second,
        "passes": out.stats.passes,
        "threads": out.stats.threads,
        "rejected_samples": out.stats.rejected_samples,
        "mean_rgb": mean,
        "warnings": loaded.warnings,
        "guiding": record.guiding,
        "iterations": record.iterations,
    });
    let json_path = output.with_extension("json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("writing {}", json_path.display()))?;
    eprintln!(
        "{}: {} spp in {:.2} s ({:.2} Msamples/s), mean RGB [{:.5}, {:.5}, {:.5}]{}",
        output.display(),
        out.stats.spp,
        out.stats.seconds,
        out.stats.samples_per_second / 1e6,
        mean[0],
        mean[1],
        mean[2],
        if interrupted { " (interrupted)" } else { "" }
    );
    Ok(())
}
