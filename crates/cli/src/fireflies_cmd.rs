//! `focal fireflies`: which samples of a render with a trained guide carry its error, and what their
//! paths did (see `focal_render::diagnostics::fireflies`).

use crate::guiding_args::{guided_spec, load_guide_for};
use crate::input_checks;
use crate::json_out;
use crate::render_cmd::{parse_defines, parse_res, parse_sampler, GuidingArgs};
use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::diagnostics::fireflies::{find_fireflies, Firefly};
use focal_render::film::Image;
use focal_render::integrator::path_trace::{LightEvent, PathTrace, Strategy};
use focal_render::integrator::GuidedPathIntegrator;
use focal_render::load::load_scene;
use focal_render::render::RenderSettings;
use focal_render::scene::{BuildOptions, Strictness};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Arguments of `focal fireflies`.
#[derive(Args, Debug)]
pub struct FirefliesArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// The reference image (EXR) the samples are scored against.
    #[arg(long)]
    pub reference: PathBuf,
    /// Samples per pixel (the same samples as `render --load-guide` with this --spp and --seed).
    #[arg(long)]
    pub spp: u32,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// How many of the highest-scoring samples to list.
    #[arg(long, default_value_t = 20)]
    pub top: usize,
    /// ε of relMSE.
    #[arg(long, default_value_t = focal_render::eval::metrics::DEFAULT_REL_EPSILON)]
    pub epsilon: f64,
    /// Also write the report, with every listed sample's whole path, as JSON to PATH (`-`: standard
    /// output).
    #[arg(long, value_name = "PATH")]
    pub json: Option<PathBuf>,
    /// Worker threads: 0 (the default) means one per core; at most 4 per core.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Scene parameter override, `name=value` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Film size, `W` or `WxH` (with only W, the film's aspect ratio is kept).
    #[arg(long, value_name = "W[xH]")]
    pub res: Option<String>,
    /// Replace the scene's integrator (e.g. `path`).
    #[arg(long)]
    pub integrator: Option<String>,
    /// Sample generator (independent or sobol; default: the scene's).
    #[arg(long)]
    pub sampler: Option<String>,
    /// The trained guide (from `focal render --save-guide`); its method comes from the file.
    #[arg(long, value_name = "PATH")]
    pub load_guide: PathBuf,
    /// Use the guide even if it was trained on another scene.
    #[arg(long)]
    pub force_guide: bool,
    /// Probability of sampling the guide instead of the BSDF at every guided vertex (as `render`).
    #[arg(long)]
    pub guide_fraction: Option<f32>,
    /// Russian roulette: albedo (default), throughput or off (as `render`).
    #[arg(long)]
    pub rr: Option<String>,
    /// Do not split guided paths (as `render --no-split`).
    #[arg(long)]
    pub no_split: bool,
}

/// The guided options of `render` that `fireflies` takes.
fn guiding_args(a: &FirefliesArgs) -> GuidingArgs {
    GuidingArgs {
        guiding: None,
        iterations: None,
        train_fraction: None,
        combine: "variance".to_string(),
        guide_fraction: a.guide_fraction,
        rr: a.rr.clone(),
        no_escaped: false,
        no_split: a.no_split,
        no_fallback: false,
        octree_threshold: None,
        gmm_k_max: None,
        gmm_params: Vec::new(),
        save_guide: None,
        load_guide: Some(a.load_guide.clone()),
        force_guide: a.force_guide,
        guide_image: false,
        save_iterations: None,
    }
}

/// Runs `focal fireflies`.
pub fn run(a: FirefliesArgs) -> Result<()> {
    if a.spp == 0 {
        bail!("--spp must be at least 1");
    }
    input_checks::threads(a.threads)?;
    if let Some(p) = &a.json {
        json_out::check(p)?;
    }
    let params = parse_defines(&a.defines)?;
    let opts = BuildOptions {
        integrator_override: a.integrator.clone(),
        strictness: Strictness::Strict,
        film_size: a.res.as_deref().map(parse_res).transpose()?,
    };
    let loaded = load_scene(&a.scene, &params, &opts)?;
    let guide = load_guide_for(&a.load_guide, &loaded.scene, &a.scene, a.force_guide)?;
    let spec = guided_spec(
        &loaded.integrator,
        &guiding_args(&a),
        Some((&a.load_guide, guide.method)),
    )?
    .context("a loaded guide makes a guided render")?;
    let guide = guide
        .guide(&spec.params)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.load_guide.display()))?;
    let reference = Image::read_exr(&a.reference)
        .with_context(|| format!("reading {}", a.reference.display()))?;
    let settings = RenderSettings {
        spp: a.spp,
        time_limit: None,
        seed: a.seed,
        threads: a.threads,
        aovs: false,
        sampler: match &a.sampler {
            Some(s) => parse_sampler(s)?,
            None => loaded.sampler.kind,
        },
        ..RenderSettings::default()
    };
    let integrator = GuidedPathIntegrator {
        settings: spec.settings,
        guide: Some(guide.as_ref()),
    };
    let report = find_fireflies(
        &loaded.scene,
        &loaded.camera,
        &loaded.film,
        &integrator,
        &settings,
        &reference,
        a.epsilon,
        a.top,
    )
    .map_err(anyhow::Error::msg)?;

    println!(
        "{} samples ({} spp): relMSE implied by the samples {:.4e}; the {} listed hold {:.1} % of it",
        report.samples,
        report.spp,
        report.implied_rel_mse,
        report.fireflies.len(),
        100.0 * report.top_share
    );
    println!(
        "{:>4} {:>11} {:>6} {:>11} {:>10} {:>7}  path (depth bsdf strategy α p_bsdf p_guide weight [1/q]) → light",
        "rank", "pixel", "sample", "value", "reference", "share%"
    );
    for (i, f) in report.fireflies.iter().enumerate() {
        println!(
            "{:>4} {:>11} {:>6} {:>11.4e} {:>10.4e} {:>7.2}  {}",
            i + 1,
            format!("{},{}", f.pixel[0], f.pixel[1]),
            f.sample_index,
            f.value,
            f.reference,
            100.0 * f.score / report.total_score.max(f64::MIN_POSITIVE),
            describe(&f.trace)
        );
    }
    println!("what the listed samples share (counts):");
    for (what, n) in tally(&report.fireflies) {
        println!("  {n:>4}  {what}");
    }
    if let Some(p) = &a.json {
        json_out::write(p, &report)?;
    }
    Ok(())
}

fn strategy_name(s: Strategy) -> &'static str {
    match s {
        Strategy::Bsdf => "bsdf",
        Strategy::Guide => "guide",
        Strategy::Delta => "delta",
    }
}

fn event_name(e: LightEvent) -> &'static str {
    match e {
        LightEvent::NextEvent => "next-event",
        LightEvent::EmitterHit => "emitter hit",
        LightEvent::Environment => "environment",
    }
}

/// A one-line account of a path: the vertices of the copy that added most light, from the camera on
/// (see [`PathTrace::lineage`]), then that light.
fn describe(t: &PathTrace) -> String {
    let light = t.dominant_light();
    let mut parts: Vec<String> = t
        .lineage(light.map_or(0, |l| l.branch))
        .iter()
        .map(|v| {
            let mut s = format!("{} {} {}", v.depth, v.bsdf, strategy_name(v.strategy));
            if v.guide_fraction > 0.0 {
                s += &format!(
                    " α{:.2} {:.3e} {:.3e}",
                    v.guide_fraction, v.bsdf_pdf, v.guide_pdf
                );
            }
            s += &format!(" w{:.3}", v.weight);
            if v.survival < 1.0 {
                s += &format!(" [{:.2}]", 1.0 / v.survival);
            }
            if v.split > 1.0 {
                s += &format!(" split×{:.2}", v.split);
            }
            s
        })
        .collect();
    if let Some(l) = light {
        parts.push(format!("→ {} after {}", event_name(l.event), l.depth));
    }
    if t.branches > 0 {
        parts.push(format!("({} split-off copies)", t.branches));
    }
    parts.join(" | ")
}

/// Counts, over the listed samples, of how the dominant light was found and how the vertex that chose
/// the direction to it (for an emitter hit; the vertex itself for next-event estimation) sampled, and of
/// Russian-roulette boosts above 2 along the path (the copy's lineage, where the path was split).
fn tally(fireflies: &[Firefly]) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for f in fireflies {
        let t = &f.trace;
        let Some(l) = t.dominant_light() else {
            *counts
                .entry("no light (value below the reference)".to_string())
                .or_insert(0) += 1;
            continue;
        };
        let lineage = t.lineage(l.branch);
        let key = match l.event {
            LightEvent::NextEvent => format!("next-event at depth {}", l.depth),
            _ => {
                let last = l.depth.checked_sub(1).and_then(|d| lineage.get(d as usize));
                match last {
                    Some(v) => format!(
                        "{} after depth {}, chosen by {} at {}{}",
                        event_name(l.event),
                        l.depth,
                        strategy_name(v.strategy),
                        v.bsdf,
                        if v.guide_fraction > 0.0 {
                            " (guided vertex)"
                        } else {
                            ""
                        }
                    ),
                    None => format!("{} seen directly", event_name(l.event)),
                }
            }
        };
        *counts.entry(key).or_insert(0) += 1;
        let boost: f32 = lineage.iter().map(|v| 1.0 / v.survival).product();
        if boost > 2.0 {
            *counts
                .entry("Russian roulette boosted the path more than 2×".to_string())
                .or_insert(0) += 1;
        }
    }
    counts
}
