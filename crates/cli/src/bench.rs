//! `focal bench`: path-tracing throughput on the reference scenes, side by side with Mitsuba 3's figure.

use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::load::{load_scene, make_integrator};
use focal_render::render::{render, RenderSettings};
use focal_render::sampler::SamplerKind;
use focal_render::scene::BuildOptions;
use std::path::PathBuf;

/// Arguments of `focal bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// The folder with `scenes/` and `mitsuba3/` (the reference scenes and their Mitsuba 3 renders,
    /// vendored in the repository; the default is relative to the repository's root).
    #[arg(long, default_value = "tests/data/references")]
    pub references: PathBuf,
    /// Scenes (names in `scenes/` without .xml).
    #[arg(long, value_delimiter = ',', default_value = "cbox,caustic")]
    pub scenes: Vec<String>,
    /// Samples per pixel per run.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Image size (square).
    #[arg(long, default_value_t = 256)]
    pub res: u32,
    /// Runs per scene (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeats: usize,
    /// Worker threads: 0 (the default) means one per core; at most 4 per core.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Also write the results as JSON to PATH (`-`: standard output).
    #[arg(long, value_name = "PATH")]
    pub json: Option<PathBuf>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Runs `focal bench`.
pub fn run(a: BenchArgs) -> Result<()> {
    if a.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    if a.spp == 0 || a.res == 0 || a.res > focal_render::film::MAX_FILM_SIDE {
        bail!(
            "--spp must be at least 1 and --res in 1..={}",
            focal_render::film::MAX_FILM_SIDE
        );
    }
    crate::input_checks::threads(a.threads)?;
    if let Some(p) = &a.json {
        crate::json_out::check(p)?;
    }
    let mut rows = Vec::new();
    println!(
        "{:<10} {:>6} {:>14} {:>16} {:>8}",
        "scene", "spp", "focal Ms/s", "mitsuba3 Ms/s", "ratio"
    );
    for name in &a.scenes {
        let path = a.references.join("scenes").join(format!("{name}.xml"));
        let params = vec![("res".to_string(), a.res.to_string())];
        let loaded = load_scene(&path, &params, &BuildOptions::default())?;
        let integrator = make_integrator(&loaded.integrator);
        let settings = RenderSettings {
            spp: a.spp,
            time_limit: None,
            seed: 1,
            threads: a.threads,
            aovs: false,
            sampler: SamplerKind::Independent,
            ..RenderSettings::default()
        };
        let mut rates: Vec<f64> = (0..a.repeats)
            .map(|_| {
                render(
                    &loaded.scene,
                    &loaded.camera,
                    &loaded.film,
                    integrator.as_ref(),
                    &settings,
                    &|_| {},
                )
                .stats
                .samples_per_second
            })
            .collect();
        let focal = median(&mut rates);
        // Mitsuba 3's measured throughput for the same scene, if its JSON is present.
        let mitsuba = std::fs::read_dir(a.references.join("mitsuba3"))
            .ok()
            .and_then(|dir| {
                dir.filter_map(|e| e.ok()).map(|e| e.path()).find(|p| {
                    p.extension().is_some_and(|e| e == "json")
                        && p.file_name()
                            .and_then(|f| f.to_str())
                            .is_some_and(|f| f.starts_with(&format!("{name}_")))
                })
            })
            .map(|p| -> Result<(String, f64)> {
                let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p)?)
                    .with_context(|| format!("reading {}", p.display()))?;
                Ok((
                    v["variant"].as_str().unwrap_or("?").to_string(),
                    v["samples_per_s"].as_f64().unwrap_or(f64::NAN),
                ))
            })
            .transpose()?;
        let (variant, mts) = mitsuba.unwrap_or(("-".into(), f64::NAN));
        println!(
            "{:<10} {:>6} {:>14.3} {:>16} {:>8}",
            name,
            a.spp,
            focal / 1e6,
            if mts.is_finite() {
                format!("{:.3} ({variant})", mts / 1e6)
            } else {
                "-".into()
            },
            if mts.is_finite() {
                format!("{:.2}x", focal / mts)
            } else {
                "-".into()
            }
        );
        rows.push(serde_json::json!({
            "scene": name, "spp": a.spp, "res": a.res, "repeats": a.repeats,
            "focal_samples_per_s_median": focal, "focal_samples_per_s_all": rates,
            "mitsuba3_variant": variant, "mitsuba3_samples_per_s": mts,
            "ratio": focal / mts,
        }));
    }
    if let Some(p) = &a.json {
        crate::json_out::write(p, &rows)?;
    }
    Ok(())
}
