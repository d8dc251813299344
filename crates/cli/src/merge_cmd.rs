//! `focal merge`: combines independent renders of one scene (different seeds, different machines) into
//! one image, weighted by their sample counts, so a render can be split over a job scheduler.

use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::film::Image;
use focal_render::render::merge::merge_images;
use std::path::{Path, PathBuf};

/// Arguments of `focal merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The renders (EXR), each with its JSON sidecar (`NAME.json`, which gives its spp).
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<PathBuf>,
    /// The merged EXR (a JSON sidecar with the total spp is written beside it, so merges compose).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write a tonemapped PNG.
    #[arg(long)]
    pub png: bool,
}

/// The sample count of a render from its JSON sidecar.
fn sidecar_spp(exr: &Path) -> Result<(u64, serde_json::Value)> {
    let json = exr.with_extension("json");
    let text = std::fs::read_to_string(&json).with_context(|| {
        format!(
            "{}: no JSON sidecar {} to take the sample count from",
            exr.display(),
            json.display()
        )
    })?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", json.display()))?;
    match v["spp"].as_u64() {
        Some(n) if n > 0 => Ok((n, v)),
        _ => bail!("{}: no positive \"spp\" field", json.display()),
    }
}

/// Runs `focal merge`.
pub fn run(a: MergeArgs) -> Result<()> {
    let mut inputs = Vec::new();
    let mut seeds = Vec::new();
    let mut scene = None;
    for p in &a.inputs {
        let (spp, sidecar) = sidecar_spp(p)?;
        let image = Image::read_exr(p).with_context(|| format!("reading {}", p.display()))?;
        seeds.push(sidecar["seed"].clone());
        let s = sidecar["scene"].clone();
        match &scene {
            None => scene = Some(s),
            Some(first) if first != &s => eprintln!(
                "warning: {} is a render of {s}, the first input of {first}",
                p.display()
            ),
            _ => {}
        }
        inputs.push((image, spp));
    }
    let mut distinct = seeds.clone();
    distinct.sort_by_key(|s| s.to_string());
    distinct.dedup();
    if distinct.len() < seeds.len() {
        eprintln!("warning: some inputs share a seed; their noise is not independent");
    }
    let merged =
        merge_images(&inputs).map_err(|e| anyhow::anyhow!("{e} (inputs in the order given)"))?;
    merged
        .write_exr(&a.output)
        .with_context(|| format!("writing {}", a.output.display()))?;
    if a.png {
        let p = a.output.with_extension("png");
        merged
            .write_png(&p, 0.0)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    let total: u64 = inputs.iter().map(|(_, n)| n).sum();
    let sidecar = serde_json::json!({
        "focal_version": env!("CARGO_PKG_VERSION"),
        "kind": "merge",
        "scene": scene,
        "output": a.output.display().to_string(),
        "inputs": a.inputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "input_spp": inputs.iter().map(|(_, n)| n).collect::<Vec<_>>(),
        "seeds": seeds,
        "spp": total,
        "mean_rgb": merged.mean_rgb(),
    });
    let json = a.output.with_extension("json");
    std::fs::write(&json, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("writing {}", json.display()))?;
    eprintln!(
        "{}: {} inputs, {total} spp",
        a.output.display(),
        inputs.len()
    );
    Ok(())
}
