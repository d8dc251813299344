//! `focal render`.

pub use crate::guiding_args::GuidingArgs;
use crate::guiding_args::{guided_spec, load_guide_for, save_guide_for};
use crate::input_checks;
use crate::interrupt;
use crate::render_args::RenderArgs;
use crate::render_output::{write_render, RenderRecord};
use crate::shard::Shard;
use anyhow::{bail, Context, Result};
use focal_render::diagnostics::colour_map::false_colour_log;
use focal_render::diagnostics::guide_view::{guide_pdf_image, guide_structure_image};
use focal_render::guide::make_guide;
use focal_render::load::{load_scene, make_integrator};
use focal_render::render::combine::Combine;
use focal_render::render::guided::{render_guided, GuidedRenderSettings, TrainingBudget};
use focal_render::render::memory::{guided_render_bytes, plain_render_bytes};
use focal_render::render::{render, RenderSettings};
use focal_render::sampler::SamplerKind;
use focal_render::scene::{BuildOptions, Strictness};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

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

/// Parses `--res W` or `--res WxH` into the film size of [`BuildOptions::film_size`].
pub fn parse_res(res: &str) -> Result<(u32, Option<u32>)> {
    let side = |s: &str| -> Result<u32> {
        let v: u32 = s
            .trim()
            .parse()
            .with_context(|| format!("--res {res}: expected W or WxH in pixels"))?;
        let max = focal_render::film::MAX_FILM_SIDE;
        if v == 0 || v > max {
            bail!("--res {res}: each side must be in 1..={max}");
        }
        Ok(v)
    };
    match res.split_once(['x', 'X']) {
        Some((w, h)) => Ok((side(w)?, Some(side(h)?))),
        None => Ok((side(res)?, None)),
    }
}

/// Runs `focal render`.
pub fn run(a: RenderArgs) -> Result<()> {
    // Everything the command line alone can get wrong is checked before the scene is even loaded.
    let params = parse_defines(&a.defines)?;
    let film_size = a.res.as_deref().map(parse_res).transpose()?;
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
    let time_limit = a
        .time
        .map(|t| input_checks::time_budget("--time", t))
        .transpose()?;
    input_checks::threads(a.threads)?;
    if a.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    let output = a.output.clone().unwrap_or_else(|| {
        PathBuf::from(a.scene.file_stem().unwrap_or_default()).with_extension("exr")
    });
    input_checks::output_file("-o", &output, "exr", "the image")?;
    if let Some(p) = &a.guiding.save_guide {
        input_checks::output_any("--save-guide", p)?;
    }
    if let Some(dir) = &a.guiding.save_iterations {
        input_checks::output_folder("--save-iterations", dir)?;
    }
    let sampler_override = a.sampler.as_deref().map(parse_sampler).transpose()?;
    let combine = match a.guiding.combine.as_str() {
        "variance" | "inverse-variance" => Combine::InverseVariance,
        "last" => Combine::Last,
        other => bail!("unknown --combine '{other}' (variance or last)"),
    };
    let first_sample = match (&shard, a.spp, a.time) {
        (None, ..) => 0,
        (Some(_), _, Some(_)) => {
            bail!(
                "--shard needs a sample budget (--spp), not --time: shards must know their samples"
            )
        }
        (Some(_), None, None) => bail!("--shard needs --spp (the samples per pixel of each shard)"),
        (Some(s), Some(spp), None) => s.first_sample(spp)?,
    };

    let opts = BuildOptions {
        integrator_override: a.integrator.clone(),
        strictness: if a.lenient {
            Strictness::Lenient
        } else {
            Strictness::Strict
        },
        film_size,
    };
    let load_start = std::time::Instant::now();
    let loaded = load_scene(&a.scene, &params, &opts)?;
    let load_seconds = load_start.elapsed().as_secs_f64();
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    let g = &a.guiding;
    let mut pretrained = match &g.load_guide {
        Some(p) => Some(load_guide_for(p, &loaded.scene, &a.scene, g.force_guide)?),
        None => None,
    };
    let guided = guided_spec(
        &loaded.integrator,
        g,
        pretrained
            .as_ref()
            .zip(g.load_guide.as_deref())
            .map(|(l, p)| (p, l.method)),
    )?;
    if shard.is_some() && guided.is_some() && pretrained.is_none() {
        bail!(
            "--shard of a guided render needs a trained guide: train once with --save-guide, then \
             render every shard with --load-guide (see docs/sharding.md)"
        );
    }
    let scene_budget = guided.as_ref().and_then(|s| s.budget_s);
    if a.time.is_none() {
        if let Some(t) = scene_budget {
            input_checks::time_budget("the scene's integrator budget", t)?;
        }
    }
    let spp = match (a.spp, a.time.or(scene_budget)) {
        (Some(s), _) => s,
        (None, Some(_)) => u32::MAX,
        (None, None) => loaded.sampler.spp,
    };
    if spp == 0 {
        bail!("the scene's sample_count must be at least 1");
    }
    let needed = match &guided {
        None => plain_render_bytes(&loaded.film, a.aovs),
        Some(spec) => {
            let iterations = g.iterations.or(spec.iterations).unwrap_or(16);
            guided_render_bytes(&loaded.film, a.aovs, iterations)
        }
    };
    let (fw, fh) = (loaded.film.crop_size.x, loaded.film.crop_size.y);
    input_checks::memory(needed, &format!("a {fw}x{fh} film"))?;

    let cancel = interrupt::install();
    let settings = RenderSettings {
        spp,
        time_limit,
        seed: a.seed,
        threads: a.threads,
        aovs: a.aovs,
        sampler: sampler_override.unwrap_or(loaded.sampler.kind),
        cancel,
        first_sample,
        filter_weights: shard.is_some(),
    };
    let integrator = make_integrator(&loaded.integrator);
    let bar = progress_bar(&a);
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
    let mut record = RenderRecord::default();
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
            let mut guide = match pretrained.take().zip(g.load_guide.as_deref()) {
                Some((file, path)) => Some(
                    file.guide(&spec.params)
                        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
                ),
                None => make_guide(spec.method, &loaded.scene.bounds, &spec.params)
                    .map_err(|e| anyhow::anyhow!(e))?,
            };
            let budget = match a.time.or(spec.budget_s) {
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
                    .map(|g| g.as_mut() as &mut dyn focal_render::guiding::GuidingField),
                &gsettings,
                &progress,
            );
            let interrupted = interrupt::interrupted();
            let mut guide_caption = None;
            if let (true, Some(guide), false) = (g.guide_image, &guide, interrupted) {
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
            // An interrupted training leaves a guide that was not updated with its last iteration's
            // samples: it is not saved as if it were the trained guide.
            if let (Some(p), Some(guide)) = (&g.save_guide, &guide) {
                if interrupted && g.load_guide.is_none() {
                    eprintln!(
                        "warning: training was interrupted; the guide is not saved to {}",
                        p.display()
                    );
                } else {
                    save_guide_for(p, guide.as_ref(), spec.method, &loaded.scene, &a.scene)?;
                }
            }
            record.iterations = serde_json::to_value(&out.iterations)?;
            record.guiding = serde_json::json!({
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
    record.shard = shard.map(|s| s.record(first_sample));
    record.load_seconds = load_seconds;
    write_render(&a, &output, &loaded, &params, &settings, out, record)
}

/// The progress bar of a render (hidden with --quiet).
fn progress_bar(a: &RenderArgs) -> ProgressBar {
    if a.quiet {
        return ProgressBar::hidden();
    }
    if let Some(t) = a.time {
        let b = ProgressBar::new((t * 1000.0) as u64);
        b.set_style(
            ProgressStyle::with_template("{bar:40.cyan/blue} {elapsed_precise}/{msg} {prefix}")
                .expect("valid template"),
        );
        b.set_message(format!("{t:.1}s"));
        return b;
    }
    let b = ProgressBar::new(0);
    b.set_style(
        ProgressStyle::with_template(
            "{bar:40.cyan/blue} {percent:>3}% {human_pos}/{human_len} samples  {elapsed_precise} ETA {eta_precise}  {prefix}",
        )
        .expect("valid template"),
    );
    b
}
