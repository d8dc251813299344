//! `focal compare`: renders a scene with several methods at equal time (or equal spp) and several seeds,
//! and tabulates their errors against a reference: images, false-colour error images, metrics CSV/JSON,
//! convergence curves (SVG) and an interactive, offline `index.html`.

use crate::compare_args::CompareArgs;
use crate::compare_checks::{
    check_compare_args, reference_noise_warning, reference_rel_variance, CompareInputs,
};
use crate::convergence_plot::{write_loglog_svg, Curve};
use crate::flip::{flip_picture, ldr_flip};
use crate::interrupt;
use crate::render_args::RenderArgs;
use crate::render_cmd::{self, GuidingArgs};
use crate::report_html::{write_report, Figure, ReportPage, ViewerImage};
use anyhow::{bail, Context, Result};
use focal_render::color::srgb_to_linear;
use focal_render::diagnostics::colour_map::viridis;
use focal_render::eval::metrics::{image_errors, per_pixel_errors, ImageErrors};
use focal_render::eval::score::{score, Score};
use focal_render::eval::two_reference::two_reference_rel_mse;
use focal_render::film::Image;
use std::path::Path;

/// One point of a convergence curve: a whole run of a method at a fraction of the budget.
#[derive(serde::Serialize)]
struct CurvePoint {
    method: String,
    seed: u64,
    /// k of budget / 2^k.
    budget_halvings: u32,
    spp: u64,
    seconds: f64,
    errors: ImageErrors,
    /// relMSE against the true image from both references (with `--second-reference`).
    rel_mse_two_references: Option<f64>,
}

/// What `compare` reads back from one finished run.
struct Judgement {
    image: Image,
    errors: ImageErrors,
    rel_mse_two_references: Option<f64>,
    score: Score,
    spp: u64,
    seconds: f64,
}

/// One render's numbers.
#[derive(serde::Serialize)]
struct Row {
    method: String,
    seed: u64,
    spp: u64,
    seconds: f64,
    errors: ImageErrors,
    /// Mean LDR-FLIP of the PNG tonemapping (`--exposure`).
    ldr_flip: f64,
    /// relMSE against the true image from both references (with `--second-reference`).
    rel_mse_two_references: Option<f64>,
    /// The benchmark's score (bias check, exposure-normalised relMSE): see `focal_render::eval::score`.
    score: Score,
}

/// Runs `focal compare`.
pub fn run(a: CompareArgs) -> Result<()> {
    let CompareInputs {
        methods,
        reference,
        second_reference,
    } = check_compare_args(&a)?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    // A reference rendered with one of the runs' seeds shares their first samples: its error would be
    // too small for the unguided methods. Two references of one seed share theirs, which the
    // two-reference estimate assumes they do not.
    let sidecar_of = |p: &Path| {
        std::fs::read_to_string(p.with_extension("json"))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
    };
    let seed_of = |p: &Path| sidecar_of(p).and_then(|v| v["seed"].as_u64());
    let seeds: Vec<Option<u64>> = std::iter::once(&a.reference)
        .chain(&a.second_reference)
        .map(|p| seed_of(p))
        .collect();
    for seed in seeds.iter().flatten().filter(|s| **s < a.seeds) {
        eprintln!(
            "warning: a reference was rendered with seed {seed}, which the runs use too; \
             its noise is correlated with theirs (render references with `focal reference`, \
             whose default seed avoids this)"
        );
    }
    if let [Some(s1), Some(s2)] = seeds[..] {
        if s1 == s2 {
            eprintln!(
                "warning: both references were rendered with seed {s1}: if by the same method, \
                 their noise is shared and the error against the truth comes out too small"
            );
        }
    }
    let mut rows = Vec::new();
    let curve_dir = a.out.join("curves");
    let mut curve = Vec::new();
    // Ctrl-C stops the run under way; the finished runs are judged and reported as usual.
    'runs: for method in &methods {
        for seed in 0..a.seeds {
            // Smaller budgets first: independent, complete runs (training included) whose output is what
            // the method returns when given that budget.
            for k in (1..a.curve_points).rev() {
                std::fs::create_dir_all(&curve_dir)
                    .with_context(|| format!("creating {}", curve_dir.display()))?;
                let output = curve_dir.join(format!("{method}_s{seed}_k{k}.exr"));
                let mut args = run_args(&a, method, seed, &output, false);
                args.png = false;
                args.spp = a.spp.map(|n| (n >> k).max(1));
                args.time = a.time.map(|t| t / (1u64 << k) as f64);
                let rendered = render_cmd::run(args);
                if interrupt::interrupted() {
                    break 'runs;
                }
                rendered.with_context(|| format!("rendering with {method}"))?;
                let j = judge(&output, &reference, second_reference.as_ref(), &a)?;
                for ext in ["exr", "json"] {
                    let _ = std::fs::remove_file(output.with_extension(ext));
                }
                curve.push(CurvePoint {
                    method: method.clone(),
                    seed,
                    budget_halvings: k,
                    spp: j.spp,
                    seconds: j.seconds,
                    errors: j.errors,
                    rel_mse_two_references: j.rel_mse_two_references,
                });
            }
            let output = a.out.join(format!("{method}_s{seed}.exr"));
            let guide_image = seed == 0 && method != "pt" && method != "none";
            let args = run_args(&a, method, seed, &output, guide_image);
            let rendered = render_cmd::run(args);
            if interrupt::interrupted() {
                eprintln!(
                    "interrupted: {} is not judged (it did not get its budget); the finished runs are",
                    output.display()
                );
                break 'runs;
            }
            rendered.with_context(|| format!("rendering with {method}"))?;
            let Judgement {
                image,
                errors,
                rel_mse_two_references,
                score,
                spp,
                seconds,
            } = judge(&output, &reference, second_reference.as_ref(), &a)?;
            warn_if_like_black(method, seed, &score);
            if seed == 0 {
                write_error_image(
                    &image,
                    &reference,
                    a.epsilon,
                    &a.out.join(format!("{method}_relmse.png")),
                )?;
            }
            curve.push(CurvePoint {
                method: method.clone(),
                seed,
                budget_halvings: 0,
                spp,
                seconds,
                errors,
                rel_mse_two_references,
            });
            let (ldr_flip, flip_map) = ldr_flip(&image, &reference, a.exposure)?;
            if seed == 0 {
                let p = a.out.join(format!("{method}_flip.png"));
                flip_picture(&flip_map)
                    .write_png(&p, 0.0)
                    .with_context(|| format!("writing {}", p.display()))?;
            }
            rows.push(Row {
                method: method.clone(),
                seed,
                spp,
                seconds,
                errors,
                ldr_flip,
                rel_mse_two_references,
                score,
            });
        }
    }
    let _ = std::fs::remove_dir(&curve_dir);
    // The methods with a finished main run of seed 0 (all of them unless interrupted).
    let methods: Vec<String> = methods
        .into_iter()
        .filter(|m| rows.iter().any(|r| &r.method == m && r.seed == 0))
        .collect();
    if methods.is_empty() {
        bail!("interrupted before the first run finished: nothing to compare");
    }
    rows.retain(|r| methods.contains(&r.method));
    curve.retain(|c| methods.contains(&c.method));
    let mut csv = String::from(
        "method,seed,spp,seconds,rel_mse,mse,mape,smape,ldr_flip,rel_mse_two_references\n",
    );
    for r in &rows {
        csv += &format!(
            "{},{},{},{:.3},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{}\n",
            r.method,
            r.seed,
            r.spp,
            r.seconds,
            r.errors.rel_mse,
            r.errors.mse,
            r.errors.mape,
            r.errors.smape,
            r.ldr_flip,
            r.rel_mse_two_references
                .map_or(String::new(), |v| format!("{v:.6e}"))
        );
    }
    std::fs::write(a.out.join("metrics.csv"), csv)?;
    let mut ccsv = String::from(
        "method,seed,budget_halvings,spp,seconds,rel_mse,mse,mape,smape,rel_mse_two_references\n",
    );
    for c in &curve {
        ccsv += &format!(
            "{},{},{},{},{:.3},{:.6e},{:.6e},{:.6e},{:.6e},{}\n",
            c.method,
            c.seed,
            c.budget_halvings,
            c.spp,
            c.seconds,
            c.errors.rel_mse,
            c.errors.mse,
            c.errors.mape,
            c.errors.smape,
            c.rel_mse_two_references
                .map_or(String::new(), |v| format!("{v:.6e}"))
        );
    }
    std::fs::write(a.out.join("convergence.csv"), ccsv)?;
    let summaries: Vec<Summary> = methods.iter().map(|m| summarise(m, &rows)).collect();
    let lowest = summaries
        .iter()
        .min_by(|x, y| x.rel_mse_mean.total_cmp(&y.rel_mse_mean))
        .map(|s| (s.method.as_str(), s.rel_mse_mean));
    if let Some(w) = reference_noise_warning(
        reference_rel_variance(&reference, a.epsilon),
        sidecar_of(&a.reference).and_then(|v| v["spp"].as_u64()),
        lowest,
        summaries.iter().find(|s| s.method == "pt").map(|s| s.spp),
    ) {
        eprintln!("warning: {w}");
    }
    std::fs::write(
        a.out.join("metrics.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "scene": a.scene.display().to_string(),
            "reference": a.reference.display().to_string(),
            "second_reference": a.second_reference.as_ref().map(|p| p.display().to_string()),
            "time_s": a.time,
            "spp": a.spp,
            "epsilon": a.epsilon,
            "outliers": a.outliers,
            "runs": rows,
            "summary": summaries,
            "convergence": curve,
        }))? + "\n",
    )?;
    let mut header = vec![
        "method",
        "seeds",
        "spp",
        "seconds",
        "relMSE mean",
        "relMSE std",
        "relMSE median",
        "MSE",
        "MAPE",
        "SMAPE",
        "LDR-FLIP",
        "relMSE / first",
    ];
    if second_reference.is_some() {
        header.push("relMSE vs truth (two references)");
    }
    let base = summaries.first().map_or(1.0, |s| s.rel_mse_mean);
    let table_rows: Vec<Vec<String>> = summaries
        .iter()
        .map(|s| {
            vec![
                s.method.clone(),
                s.seeds.to_string(),
                format!("{:.0}", s.spp),
                format!("{:.2}", s.seconds),
                format!("{:.4e}", s.rel_mse_mean),
                s.rel_mse_std
                    .map_or("n/a (one seed)".to_string(), |v| format!("{v:.2e}")),
                format!("{:.4e}", s.rel_mse_median),
                format!("{:.4e}", s.mse),
                format!("{:.4}", s.mape),
                format!("{:.4}", s.smape),
                format!("{:.4}", s.ldr_flip),
                format!("{:.3}", s.rel_mse_mean / base),
            ]
            .into_iter()
            .chain(s.rel_mse_two_references_mean.map(|t| format!("{t:.4e}")))
            .collect()
        })
        .collect();
    println!(
        "{:<8} {:>6} {:>8} {:>13} {:>13} {:>10} {:>10}",
        "method", "seeds", "spp", "relMSE(mean)", "relMSE(med)", "MAPE", "vs first"
    );
    for s in &summaries {
        println!(
            "{:<8} {:>6} {:>8.0} {:>13.4e} {:>13.4e} {:>10.4} {:>10.3}",
            s.method,
            s.seeds,
            s.spp,
            s.rel_mse_mean,
            s.rel_mse_median,
            s.mape,
            s.rel_mse_mean / base
        );
    }
    if let Some(base_truth) = summaries
        .first()
        .and_then(|s| s.rel_mse_two_references_mean)
    {
        println!(
            "relMSE against the true image, both references' noise taken out (mean over seeds):"
        );
        for s in &summaries {
            if let Some(t) = s.rel_mse_two_references_mean {
                println!("{:<8} {:>13.4e} {:>10.3}", s.method, t, t / base_truth);
            }
        }
    }

    // Convergence curves: per method and budget, the mean over seeds of the error and of the budget used;
    // the error against the truth from both references where there are two (a noisy reference flattens
    // the one-reference curves as the runs' own error approaches its).
    let truth_curves = second_reference.is_some();
    let error_of = |c: &CurvePoint| {
        if truth_curves {
            c.rel_mse_two_references.unwrap_or(f64::NAN)
        } else {
            c.errors.rel_mse
        }
    };
    let curves = |x: &dyn Fn(&CurvePoint) -> f64| -> Vec<Curve> {
        methods
            .iter()
            .map(|m| Curve {
                name: m.clone(),
                points: (0..a.curve_points)
                    .rev()
                    .filter_map(|k| {
                        let pts: Vec<&CurvePoint> = curve
                            .iter()
                            .filter(|c| &c.method == m && c.budget_halvings == k)
                            .collect();
                        (!pts.is_empty()).then(|| {
                            let n = pts.len() as f64;
                            (
                                pts.iter().map(|c| x(c)).sum::<f64>() / n,
                                pts.iter().map(|c| error_of(c)).sum::<f64>() / n,
                            )
                        })
                    })
                    .collect(),
            })
            .collect()
    };
    let y_label = format!(
        "relMSE{} (ε = {}), mean over {} seed(s)",
        if truth_curves {
            " vs truth (two references)"
        } else {
            ""
        },
        a.epsilon,
        a.seeds
    );
    write_loglog_svg(
        &a.out.join("convergence_time.svg"),
        "error vs time (training included)",
        "seconds",
        &y_label,
        &curves(&|c| c.seconds),
    )?;
    write_loglog_svg(
        &a.out.join("convergence_spp.svg"),
        "error vs samples per pixel",
        "spp",
        &y_label,
        &curves(&|c| c.spp as f64),
    )?;

    // The page.
    reference
        .write_png(&a.out.join("reference.png"), a.exposure)
        .context("writing reference.png")?;
    let mut seed0 = Vec::new();
    for m in &methods {
        seed0.push(Image::read_exr(&a.out.join(format!("{m}_s0.exr")))?);
    }
    let mut images = vec![ViewerImage {
        key: "reference".to_string(),
        label: "reference".to_string(),
        png: "reference.png".to_string(),
        image: &reference,
    }];
    for (m, im) in methods.iter().zip(&seed0) {
        images.push(ViewerImage {
            key: m.clone(),
            label: format!("{m} (seed 0)"),
            png: format!("{m}_s0.png"),
            image: im,
        });
    }
    let budget = match (a.time, a.spp) {
        (Some(t), Some(n)) => format!("equal time: {t} s per run (at most {n} spp)"),
        (Some(t), None) => format!("equal time: {t} s per run"),
        (None, Some(n)) => format!("equal samples: {n} spp per run"),
        (None, None) => unreachable!("checked above"),
    };
    let mut guides = Vec::new();
    for m in &methods {
        let pdf = format!("{m}_s0.guide.png");
        if a.out.join(&pdf).exists() {
            guides.push(Figure {
                src: pdf,
                caption: format!(
                    "{m}: guide pdf at the camera along each pixel's ray (log scale, 4 decades)"
                ),
            });
        }
        let structure = format!("{m}_s0.guide_structure.png");
        if a.out.join(&structure).exists() {
            let caption = std::fs::read_to_string(a.out.join(format!("{m}_s0.json")))
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .and_then(|v| v["guiding"]["structure_image"].as_str().map(str::to_string))
                .unwrap_or_default();
            guides.push(Figure {
                src: structure,
                caption: format!("{m}: {caption}"),
            });
        }
    }
    let page = ReportPage {
        title: format!("focal compare: {}", a.scene.display()),
        summary: vec![
            format!(
                "{budget}, training included; methods {}; {} seed(s); reference {}.",
                methods.join(", "),
                a.seeds,
                a.reference.display()
            ),
            format!(
                "relMSE = mean of (x − r)² / (r² + ε) over pixels and channels with ε = {}{}. \
                 Convergence points are independent complete runs at 1/2^k of the budget \
                 (k = {} … 0), each the image the method returns given that budget.",
                a.epsilon,
                if a.outliers > 0.0 {
                    format!(", after dropping the {}% largest per-pixel errors", a.outliers * 100.0)
                } else {
                    String::new()
                },
                a.curve_points - 1
            ),
        ],
        images,
        table_header: header.iter().map(|h| h.to_string()).collect(),
        table_rows,
        sections: vec![
            (
                "Convergence".to_string(),
                vec![
                    Figure {
                        src: "convergence_time.svg".to_string(),
                        caption: "relMSE vs wall time, log-log".to_string(),
                    },
                    Figure {
                        src: "convergence_spp.svg".to_string(),
                        caption: "relMSE vs spp, log-log".to_string(),
                    },
                ],
            ),
            (
                "Per-pixel relMSE (seed 0)".to_string(),
                methods
                    .iter()
                    .map(|m| Figure {
                        src: format!("{m}_relmse.png"),
                        caption: format!("{m}: log scale from 1e-4 (dark) to 10 (yellow)"),
                    })
                    .collect(),
            ),
            (
                "LDR-FLIP error maps (seed 0)".to_string(),
                methods
                    .iter()
                    .map(|m| Figure {
                        src: format!("{m}_flip.png"),
                        caption: format!(
                            "{m}: LDR-FLIP of the PNG tonemapping (exposure {}), magma: black = none",
                            a.exposure
                        ),
                    })
                    .collect(),
            ),
            ("What the guides learned (seed 0)".to_string(), guides),
        ],
        exposure: a.exposure,
    };
    write_report(&a.out, &page)?;
    println!(
        "(relMSE with epsilon {}; report in {})",
        a.epsilon,
        a.out.join("index.html").display()
    );
    Ok(())
}

/// Per-method aggregates over seeds.
#[derive(serde::Serialize)]
struct Summary {
    method: String,
    seeds: usize,
    spp: f64,
    seconds: f64,
    rel_mse_mean: f64,
    /// Standard deviation over seeds; `None` with one seed (one run gives no spread).
    rel_mse_std: Option<f64>,
    rel_mse_median: f64,
    mse: f64,
    mape: f64,
    smape: f64,
    ldr_flip: f64,
    /// Mean over seeds of the two-reference relMSE (with `--second-reference`).
    rel_mse_two_references_mean: Option<f64>,
}

fn summarise(method: &str, rows: &[Row]) -> Summary {
    let rs: Vec<&Row> = rows.iter().filter(|r| r.method == method).collect();
    let n = rs.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Row) -> f64| rs.iter().map(|r| f(r)).sum::<f64>() / n;
    let mut rel: Vec<f64> = rs.iter().map(|r| r.errors.rel_mse).collect();
    rel.sort_by(f64::total_cmp);
    let m = mean(&|r| r.errors.rel_mse);
    let std = (rs.len() > 1)
        .then(|| (rel.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)).sqrt());
    let median = match rel.len() {
        0 => 0.0,
        l if l % 2 == 1 => rel[l / 2],
        l => 0.5 * (rel[l / 2 - 1] + rel[l / 2]),
    };
    Summary {
        method: method.to_string(),
        seeds: rs.len(),
        spp: mean(&|r| r.spp as f64),
        seconds: mean(&|r| r.seconds),
        rel_mse_mean: m,
        rel_mse_std: std,
        rel_mse_median: median,
        mse: mean(&|r| r.errors.mse),
        mape: mean(&|r| r.errors.mape),
        smape: mean(&|r| r.errors.smape),
        ldr_flip: mean(&|r| r.ldr_flip),
        rel_mse_two_references_mean: rs
            .iter()
            .map(|r| r.rel_mse_two_references)
            .sum::<Option<f64>>()
            .map(|t| t / n),
    }
}

/// The `focal render` arguments of one run of `method`.
fn run_args(
    a: &CompareArgs,
    method: &str,
    seed: u64,
    output: &Path,
    guide_image: bool,
) -> RenderArgs {
    RenderArgs {
        scene: a.scene.clone(),
        output: Some(output.to_path_buf()),
        spp: a.spp,
        time: a.time,
        threads: a.threads,
        seed,
        defines: a.defines.clone(),
        res: a.res.clone(),
        shard: None,
        png: true,
        exposure: a.exposure,
        aovs: false,
        integrator: (method == "pt").then(|| "path".to_string()),
        sampler: None,
        lenient: false,
        quiet: true,
        guiding: GuidingArgs {
            guiding: (method != "pt").then(|| method.to_string()),
            iterations: a.iterations,
            train_fraction: a.train_fraction,
            combine: a.combine.clone(),
            guide_fraction: None,
            rr: None,
            no_escaped: false,
            no_split: false,
            no_fallback: false,
            octree_threshold: None,
            gmm_k_max: None,
            gmm_params: Vec::new(),
            save_guide: None,
            load_guide: None,
            force_guide: false,
            guide_image,
            save_iterations: None,
        },
    }
}

/// Reads back a finished run: its image, its errors against the reference(s), spp and render seconds.
fn judge(
    output: &Path,
    reference: &Image,
    second_reference: Option<&Image>,
    a: &CompareArgs,
) -> Result<Judgement> {
    let image = Image::read_exr(output)?;
    let errors =
        image_errors(&image, reference, a.epsilon, a.outliers).map_err(anyhow::Error::msg)?;
    let rel_mse_two_references = second_reference
        .map(|b| two_reference_rel_mse(&image, reference, b, a.epsilon, a.outliers))
        .transpose()
        .map_err(anyhow::Error::msg)?;
    let score = score(&image, reference, second_reference).map_err(anyhow::Error::msg)?;
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(output.with_extension("json"))?)?;
    Ok(Judgement {
        image,
        errors,
        rel_mse_two_references,
        score,
        spp: sidecar["spp"].as_u64().unwrap_or(0),
        seconds: sidecar["render_s"].as_f64().unwrap_or(0.0),
    })
}

/// Warns when a run's image is too dark or too bright to judge by its error (the bias check of
/// `focal_render::eval::score` failed), or when its error is within a factor 2 of a black image's: then an
/// image that missed the light would score as well, and the relMSE ranks nothing.
fn warn_if_like_black(method: &str, seed: u64, s: &Score) {
    if s.failed {
        eprintln!(
            "warning: {method} (seed {seed}): its image, brightest 0.1% of pixels left out, is {:.2} \
             of the reference's brightness: it missed light paths (or holds them only in fireflies)",
            s.trimmed_mean_ratio
        );
    }
    if s.scores_like_black() {
        eprintln!(
            "warning: {method} (seed {seed}): relMSE {:.3} (exposure-normalised) against {:.3} for a \
             black image: at this budget the error does not tell a render from one that found no light",
            s.rel_mse, s.black_rel_mse
        );
    }
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
