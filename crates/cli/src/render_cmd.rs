//! `focal render`.

use anyhow::{bail, Context, Result};
use clap::Args;
use focal_render::guide::{load_guide, make_guide, GuideParams, GuidingMethod};
use focal_render::integrator::{GuidedSettings, Roulette};
use focal_render::load::{load_scene, make_integrator};
use focal_render::render::combine::Combine;
use focal_render::render::guide_view::{false_colour_log, guide_pdf_image, guide_structure_image};
use focal_render::render::guided::{render_guided, GuidedRenderSettings, TrainingBudget};
use focal_render::render::{render, RenderSettings};
use focal_render::sampler::SamplerKind;
use focal_render::scene::{BuildOptions, GuidedSpec, IntegratorSpec, Strictness};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;

/// Arguments of `focal render`.
#[derive(Args, Debug, Clone)]
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
    #[command(flatten)]
    pub guiding: GuidingArgs,
}

/// Options of guided renders (`--guiding`, or a scene whose integrator is `guided`/`focal_path`).
#[derive(Args, Debug, Clone)]
pub struct GuidingArgs {
    /// Guided rendering with this guide: none, octree or gmm. Default: the scene's integrator decides.
    #[arg(long, value_name = "METHOD")]
    pub guiding: Option<String>,
    /// Training iterations (time budget: their number, default 15 as Rath et al.; sample budget: the
    /// most doubling iterations, default 16).
    #[arg(long)]
    pub iterations: Option<u32>,
    /// Share of a --time budget spent training (default 0.5).
    #[arg(long)]
    pub train_fraction: Option<f64>,
    /// How the iterations' images are combined: variance (inverse-variance weighting) or last (Rath).
    #[arg(long, default_value = "variance")]
    pub combine: String,
    /// Probability of sampling the guide instead of the BSDF at every guided vertex, for either guide.
    /// Without it the octree uses 0.5 (Rath et al.) and the GMM its own `--gmm guide_fraction=` (0.75)
    /// while training and a fraction learned per region for the final render (between
    /// `--gmm selection_min=` 0.4 and 0.75; `--gmm learn_selection=false` keeps 0.75).
    #[arg(long)]
    pub guide_fraction: Option<f32>,
    /// Russian roulette of guided renders: albedo (default; survival by the product of BSDF albedos),
    /// throughput (Mitsuba's, which undoes guiding's gains) or off (Rath et al.; set a max_depth).
    #[arg(long)]
    pub rr: Option<String>,
    /// Do not train on segments that escaped the scene (Rath et al. drop them).
    #[arg(long)]
    pub no_escaped: bool,
    /// Do not split guided paths whose throughput the sampling mixture inflated beyond the product of
    /// the BSDF albedos (by default such paths are split in renders that do not train).
    #[arg(long)]
    pub no_split: bool,
    /// Never give up guiding. By default a time-budget render compares, after every guided training
    /// iteration, the guided images so far with the unguided first iteration's; from the third check on,
    /// where guiding's relative error times its render time is more than the path tracer's (more than
    /// half of it where the guided vertices' second-moment ratio shows no gain), or more than twice it
    /// at a later check, it renders the rest of the budget unguided (the Cornell box, veach-mis).
    /// Guiding is kept whatever the images say where that ratio is at least 2, and where the comparison
    /// had nothing to go on.
    #[arg(long)]
    pub no_fallback: bool,
    /// Octree relative split threshold (orth.threshold).
    #[arg(long)]
    pub octree_threshold: Option<f64>,
    /// Most Gaussian components per mixture (converging and diverging each).
    #[arg(long)]
    pub gmm_k_max: Option<usize>,
    /// A GMM guide parameter, `name=value` (repeatable; the fields of the guide's config, e.g.
    /// `max_points=131072`, `em_iterations=2`, `decay=0.5`).
    #[arg(long = "gmm", value_name = "NAME=VALUE")]
    pub gmm_params: Vec<String>,
    /// Write the trained guide to this file after training.
    #[arg(long, value_name = "PATH")]
    pub save_guide: Option<PathBuf>,
    /// Use a guide trained earlier (--save-guide) and skip training.
    #[arg(long, value_name = "PATH")]
    pub load_guide: Option<PathBuf>,
    /// Also write the guide's pdf seen from the camera (OUT.guide.exr and a false-colour OUT.guide.png)
    /// and a picture of its structure, OUT.guide_structure.png: the Gaussian components' 2σ ellipsoids
    /// projected over the render, or the octree leaves' density on a slice through the densest leaf.
    #[arg(long)]
    pub guide_image: bool,
    /// Also write every iteration's image as its two interleaved halves, DIR/iteration_K_a.exr and
    /// _b.exr (K as the sidecar's `iterations[].index`, which gives their spp, time and weight), for
    /// studying how iterations combine.
    #[arg(long, value_name = "DIR")]
    pub save_iterations: Option<PathBuf>,
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

/// The guided render a run asks for: `--guiding` on the command line, else a guided scene integrator;
/// `None` for a plain render.
pub(crate) fn guided_spec(scene: &IntegratorSpec, g: &GuidingArgs) -> Result<Option<GuidedSpec>> {
    let mut spec = match (scene, &g.guiding) {
        (IntegratorSpec::Guided(s), _) => (**s).clone(),
        (IntegratorSpec::Path(p), Some(_)) => GuidedSpec {
            method: GuidingMethod::Octree,
            settings: GuidedSettings {
                path: *p,
                ..GuidedSettings::default()
            },
            budget_s: None,
            iterations: None,
            training_fraction: None,
            params: GuideParams::default(),
        },
        (IntegratorSpec::Path(_), None) => {
            if g.load_guide.is_some() || g.save_guide.is_some() {
                bail!("--load-guide and --save-guide need a guided render (--guiding METHOD)");
            }
            return Ok(None);
        }
    };
    if let Some(m) = &g.guiding {
        spec.method = GuidingMethod::parse(m).map_err(|e| anyhow::anyhow!(e))?;
    }
    if let Some(r) = &g.rr {
        spec.settings.roulette = Roulette::parse(r).map_err(anyhow::Error::msg)?;
    }
    if g.no_escaped {
        spec.settings.train_escaped = false;
    }
    if g.no_split {
        spec.settings.split = false;
    }
    if let Some(f) = g.guide_fraction {
        if !(0.0..1.0).contains(&f) {
            bail!("--guide-fraction must lie in [0, 1), got {f}");
        }
        spec.settings.guide_fraction = f;
        spec.settings.learned_selection = false;
    }
    if let Some(t) = g.octree_threshold {
        spec.params.octree.threshold = t;
    }
    if let Some(k) = g.gmm_k_max {
        spec.params.gmm.k_max = k;
        spec.params.gmm.k_init = spec.params.gmm.k_init.min(k);
        spec.params.gmm.k_min = spec.params.gmm.k_min.min(k);
    }
    for p in &g.gmm_params {
        spec.params.gmm = with_param(&spec.params.gmm, p).context("--gmm")?;
    }
    if let Some(f) = g.train_fraction {
        if !(0.0..=1.0).contains(&f) {
            bail!("--train-fraction must lie in [0, 1], got {f}");
        }
    }
    Ok(Some(spec))
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
    let guided = guided_spec(&loaded.integrator, &a.guiding)?;
    let mut iterations_json = serde_json::Value::Null;
    let mut guiding_json = serde_json::Value::Null;
    let mut guide_caption: Option<String> = None;
    let out = match guided {
        None => render(
            &loaded.scene,
            &loaded.camera,
            &loaded.film,
            integrator.as_ref(),
            &settings,
            &progress,
        ),
        Some(spec) => {
            let g = &a.guiding;
            let mut guide = match &g.load_guide {
                Some(p) => {
                    let bytes =
                        std::fs::read(p).with_context(|| format!("reading {}", p.display()))?;
                    Some(load_guide(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?)
                }
                None => make_guide(spec.method, &loaded.scene.bounds, &spec.params)
                    .map_err(|e| anyhow::anyhow!(e))?,
            };
            let time = a.time.or(spec.budget_s);
            let budget = match time {
                Some(seconds) => TrainingBudget::Time {
                    seconds,
                    training_fraction: g.train_fraction.or(spec.training_fraction).unwrap_or(0.5),
                    iterations: g.iterations.or(spec.iterations).unwrap_or(15),
                    max_spp: a.spp.unwrap_or(u32::MAX),
                },
                None => TrainingBudget::Samples {
                    spp,
                    max_iterations: g.iterations.or(spec.iterations).unwrap_or(16),
                },
            };
            let combine = match g.combine.as_str() {
                "variance" | "inverse-variance" => Combine::InverseVariance,
                "last" => Combine::Last,
                other => bail!("unknown --combine '{other}' (variance or last)"),
            };
            let gsettings = GuidedRenderSettings {
                render: settings.clone(),
                integrator: spec.settings,
                budget,
                combine,
                pretrained: g.load_guide.is_some(),
                fallback: !g.no_fallback,
            };
            let out = render_guided(
                &loaded.scene,
                &loaded.camera,
                &loaded.film,
                guide
                    .as_mut()
                    .map(|g| g.as_mut() as &mut dyn focal_render::guiding::GuidingDistribution),
                &gsettings,
                &progress,
            );
            if let (true, Some(guide)) = (g.guide_image, &guide) {
                let pdf = guide_pdf_image(&loaded.camera, &loaded.film, guide.as_ref());
                let exr = output.with_extension("guide.exr");
                pdf.write_exr(&exr)
                    .with_context(|| format!("writing {}", exr.display()))?;
                let png = output.with_extension("guide.png");
                false_colour_log(&pdf, 4.0)
                    .write_png(&png, 0.0)
                    .with_context(|| format!("writing {}", png.display()))?;
                // Over the image as the PNG shows it (same exposure), so the outlines sit on the scene.
                let mut shown = out.image.clone();
                shown.sanitize();
                shown.scale(2f64.powf(a.exposure as f64));
                if let Some((vis, caption)) =
                    guide_structure_image(&loaded.camera, &loaded.film, guide.as_ref(), &shown)
                {
                    let png = output.with_extension("guide_structure.png");
                    vis.write_png(&png, 0.0)
                        .with_context(|| format!("writing {}", png.display()))?;
                    guide_caption = Some(caption);
                }
            }
            if let Some(dir) = &g.save_iterations {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
                let rendered = out.iterations.iter().filter(|s| s.spp > 0);
                for (it, s) in out.iteration_images.iter().zip(rendered) {
                    for (half, (img, spp)) in [("a", &it.a), ("b", &it.b)] {
                        if *spp > 0 {
                            let p = dir.join(format!("iteration_{:02}_{half}.exr", s.index));
                            let mut img = img.clone();
                            img.sanitize();
                            img.write_exr(&p)
                                .with_context(|| format!("writing {}", p.display()))?;
                        }
                    }
                }
            }
            if let (Some(p), Some(guide)) = (&g.save_guide, &guide) {
                std::fs::write(p, guide.save())
                    .with_context(|| format!("writing {}", p.display()))?;
            }
            iterations_json = serde_json::to_value(&out.iterations)?;
            guiding_json = serde_json::json!({
                "method": spec.method.name(),
                "settings": spec.settings,
                "budget": budget,
                "combine": combine,
                "params": spec.params,
                "loaded_guide": g.load_guide.as_ref().map(|p| p.display().to_string()),
                "fallback": out.fallback,
                "structure_image": guide_caption,
            });
            focal_render::render::RenderOutput {
                image: out.image,
                stats: out.stats,
            }
        }
    };
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
        "guiding": guiding_json,
        "iterations": iterations_json,
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

/// `config` with the field named in `assignment` (`name=value`) set, through its serde form, so every
/// field of a guide's config can be set from the command line without a flag each.
fn with_param<T>(config: &T, assignment: &str) -> Result<T>
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let (name, value) = assignment
        .split_once('=')
        .with_context(|| format!("expected name=value, got `{assignment}`"))?;
    let mut json = serde_json::to_value(config)?;
    let fields = json
        .as_object_mut()
        .context("the config is not a set of named fields")?;
    let Some(old) = fields.get(name) else {
        let names: Vec<&str> = fields.keys().map(String::as_str).collect();
        bail!("unknown parameter `{name}` (known: {})", names.join(", "));
    };
    let parsed: serde_json::Value = serde_json::from_str(value)
        .or_else(|_| serde_json::from_str(&format!("\"{value}\"")))
        .with_context(|| format!("bad value `{value}` for `{name}`"))?;
    if std::mem::discriminant(old) != std::mem::discriminant(&parsed) {
        bail!("`{name}` takes a value like {old}, got `{value}`");
    }
    fields.insert(name.to_string(), parsed);
    serde_json::from_value(json).with_context(|| format!("bad value `{value}` for `{name}`"))
}
