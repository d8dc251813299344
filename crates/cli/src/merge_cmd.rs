//! `focal merge`: combines independent renders of one scene (different seeds, different machines) into
//! one image, weighted by their sample counts, so a render can be split over a job scheduler; or the
//! shards of one render (`render --shard I/N`), into exactly the image of that render.

use crate::input_checks;
use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::eval::merge::merge_images;
use focal_render::film::{Image, FILTER_WEIGHT_LAYER};
use std::path::{Path, PathBuf};

/// Arguments of `focal merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The renders (EXR), each with its JSON sidecar (`NAME.json`, which gives its spp).
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<PathBuf>,
    /// The merged EXR (a JSON sidecar with the total spp is written beside it, so merges compose).
    #[arg(short, long, visible_alias = "out", value_name = "EXR")]
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

/// Checks that the inputs are either all shards of one render, each once, or none a shard; returns
/// the shards' (index, count) in input order, if they are shards.
fn check_shards(
    paths: &[PathBuf],
    sidecars: &[serde_json::Value],
) -> Result<Option<Vec<(u64, u64)>>> {
    let shard = |v: &serde_json::Value| {
        let s = &v["shard"];
        Some((s["index"].as_u64()?, s["count"].as_u64()?))
    };
    let shards: Vec<Option<(u64, u64)>> = sidecars.iter().map(shard).collect();
    if shards.iter().all(Option::is_none) {
        return Ok(None);
    }
    if let Some(i) = shards.iter().position(Option::is_none) {
        bail!(
            "{} is not a shard (render --shard), but other inputs are: merge the shards of one \
             render first, then merge that with other renders",
            paths[i].display()
        );
    }
    let shards: Vec<(u64, u64)> = shards.into_iter().flatten().collect();
    let (_, count) = shards[0];
    for (i, (s, v)) in shards.iter().zip(sidecars).enumerate() {
        if s.1 != count {
            bail!(
                "{} is shard {}/{} but {} is a shard of {count}",
                paths[i].display(),
                s.0,
                s.1,
                paths[0].display()
            );
        }
        for key in ["seed", "spp", "sampler"] {
            if v[key] != sidecars[0][key] {
                bail!(
                    "{} has {key} {} but {} has {}: shards of one render share it",
                    paths[i].display(),
                    v[key],
                    paths[0].display(),
                    sidecars[0][key]
                );
            }
        }
        if let Some(j) = shards[..i].iter().position(|t| t.0 == s.0) {
            bail!(
                "{} and {} are both shard {}/{count}: the same samples twice",
                paths[j].display(),
                paths[i].display(),
                s.0
            );
        }
    }
    if shards.len() < count as usize {
        eprintln!(
            "warning: merging {} of {count} shards: the image has their samples only",
            shards.len()
        );
    }
    Ok(Some(shards))
}

/// Runs `focal merge`.
pub fn run(a: MergeArgs) -> Result<()> {
    input_checks::output_file("-o", &a.output, "exr", "the merged image")?;
    let mut inputs = Vec::new();
    let mut seeds = Vec::new();
    let mut scene = None;
    let mut sidecars = Vec::new();
    for p in &a.inputs {
        sidecars.push(sidecar_spp(p)?.1);
    }
    let shards = check_shards(&a.inputs, &sidecars)?;
    for (p, sidecar) in a.inputs.iter().zip(&sidecars) {
        let spp = sidecar["spp"].as_u64().expect("checked by sidecar_spp");
        let mut image = Image::read_exr(p).with_context(|| format!("reading {}", p.display()))?;
        if shards.is_none() {
            // A merge of shards is one render: merged with other renders by its sample count.
            image.layers.retain(|l| l.name != FILTER_WEIGHT_LAYER);
        }
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
    if distinct.len() < seeds.len() && shards.is_none() {
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
        "shards": shards.as_ref().map(|s| serde_json::json!({
            "count": s[0].1,
            "indices": s.iter().map(|t| t.0).collect::<Vec<_>>(),
        })),
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
