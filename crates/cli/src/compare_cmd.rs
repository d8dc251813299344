//! `focal compare`: renders a scene with several methods at equal time (or equal spp) and several seeds,
//! and tabulates their errors against a reference.

use crate::render_cmd::{self, GuidingArgs, RenderArgs};
use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::color::srgb_to_linear;
use focal_render::film::Image;
use focal_render::metrics::{image_errors, per_pixel_errors, ImageErrors};
use focal_render::render::guide_view::viridis;
use std::path::{Path, PathBuf};

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
    /// Output folder.
    #[arg(long, default_value = "compare")]
    pub out: PathBuf,
    /// Scene parameter override, `name=value` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Worker threads.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// ε of relMSE.
    #[arg(long, default_value_t = focal_render::metrics::DEFAULT_REL_EPSILON)]
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
}

/// One render's numbers.
#[derive(serde::Serialize)]
struct Row {
    method: String,
    seed: u64,
    spp: u64,
    seconds: f64,
    errors: ImageErrors,
}

/// Runs `focal compare`.
pub fn run(a: CompareArgs) -> Result<()> {
    if a.time.is_none() && a.spp.is_none() {
        bail!("give a budget: --time SECONDS (equal time) or --spp N (equal samples)");
    }
    let reference = Image::read_exr(&a.reference)
        .with_context(|| format!("reading {}", a.reference.display()))?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let methods: Vec<String> = a.methods.split(',').map(|m| m.trim().to_string()).collect();
    let mut rows = Vec::new();
    for method in &methods {
        for seed in 0..a.seeds {
            let output = a.out.join(format!("{method}_s{seed}.exr"));
            let args = RenderArgs {
                scene: a.scene.clone(),
                output: Some(output.clone()),
                spp: a.spp,
                time: a.time,
                threads: a.threads,
                seed,
                defines: a.defines.clone(),
                png: true,
                exposure: a.exposure,
                aovs: false,
                integrator: (method == "pt").then(|| "path".to_string()),
                sampler: None,
                lenient: false,
                quiet: true,
                guiding: GuidingArgs {
                    guiding: (method != "pt").then(|| method.clone()),
                    iterations: a.iterations,
                    train_fraction: a.train_fraction,
                    combine: a.combine.clone(),
                    guide_fraction: None,
                    rr: None,
                    no_escaped: false,
                    no_fallback: false,
                    octree_threshold: None,
                    gmm_k_max: None,
                    gmm_params: Vec::new(),
                    save_guide: None,
                    load_guide: None,
                    guide_image: seed == 0 && method != "pt" && method != "none",
                },
            };
            render_cmd::run(args).with_context(|| format!("rendering with {method}"))?;
            let image = Image::read_exr(&output)?;
            let errors = image_errors(&image, &reference, a.epsilon, a.outliers)
                .map_err(anyhow::Error::msg)?;
            let sidecar: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(output.with_extension("json"))?)?;
            if seed == 0 {
                write_error_image(
                    &image,
                    &reference,
                    a.epsilon,
                    &a.out.join(format!("{method}_relmse.png")),
                )?;
            }
            rows.push(Row {
                method: method.clone(),
                seed,
                spp: sidecar["spp"].as_u64().unwrap_or(0),
                seconds: sidecar["render_s"].as_f64().unwrap_or(0.0),
                errors,
            });
        }
    }
    let mut csv = String::from("method,seed,spp,seconds,rel_mse,mse,mape,smape\n");
    for r in &rows {
        csv += &format!(
            "{},{},{},{:.3},{:.6e},{:.6e},{:.6e},{:.6e}\n",
            r.method,
            r.seed,
            r.spp,
            r.seconds,
            r.errors.rel_mse,
            r.errors.mse,
            r.errors.mape,
            r.errors.smape
        );
    }
    std::fs::write(a.out.join("metrics.csv"), csv)?;
    std::fs::write(
        a.out.join("metrics.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "scene": a.scene.display().to_string(),
            "reference": a.reference.display().to_string(),
            "time_s": a.time,
            "spp": a.spp,
            "epsilon": a.epsilon,
            "outliers": a.outliers,
            "runs": rows,
        }))? + "\n",
    )?;
    println!(
        "{:<8} {:>6} {:>8} {:>13} {:>13} {:>10} {:>10}",
        "method", "seeds", "spp", "relMSE(mean)", "relMSE(med)", "MAPE", "vs first"
    );
    let mut first = None;
    for method in &methods {
        let rs: Vec<&Row> = rows.iter().filter(|r| &r.method == method).collect();
        let mut rel: Vec<f64> = rs.iter().map(|r| r.errors.rel_mse).collect();
        rel.sort_by(f64::total_cmp);
        let mean = rel.iter().sum::<f64>() / rel.len() as f64;
        let median = rel[rel.len() / 2];
        let mape = rs.iter().map(|r| r.errors.mape).sum::<f64>() / rs.len() as f64;
        let spp = rs.iter().map(|r| r.spp).sum::<u64>() / rs.len() as u64;
        let base = *first.get_or_insert(mean);
        println!(
            "{:<8} {:>6} {:>8} {:>13.4e} {:>13.4e} {:>10.4} {:>10.3}",
            method,
            rs.len(),
            spp,
            mean,
            median,
            mape,
            mean / base
        );
    }
    println!(
        "(relMSE with epsilon {}; report in {})",
        a.epsilon,
        a.out.display()
    );
    Ok(())
}

/// A false-colour image of the per-pixel relMSE, log scale from 1e-4 (dark) to 10 (bright).
fn write_error_image(image: &Image, reference: &Image, eps: f64, path: &Path) -> Result<()> {
    let [rel, ..] = per_pixel_errors(image, reference, eps).map_err(anyhow::Error::msg)?;
    let mut out = Image::new(image.width, image.height);
    for (o, e) in out.rgb.iter_mut().zip(&rel) {
        let t = ((e.max(1e-12).log10() + 4.0) / 5.0).clamp(0.0, 1.0) as f32;
        *o = viridis(t).map(srgb_to_linear);
    }
    out.write_png(path, 0.0)
        .with_context(|| format!("writing {}", path.display()))
}
