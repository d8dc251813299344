//! `focal metrics`: error metrics between two images (relMSE, MSE, MAPE, SMAPE and LDR-FLIP).

use crate::flip::ldr_flip;
use crate::json_out;
use anyhow::{Context, Result};
use clap::Args;
use focal_render::eval::agreement::{agreement, VARIANCE_LAYER};
use focal_render::eval::metrics::{image_errors, DEFAULT_REL_EPSILON, FIREFLY_PIXEL_FRACTION};
use focal_render::eval::score::score;
use focal_render::eval::two_reference::two_reference_rel_mse;
use focal_render::film::Image;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `focal metrics`.
#[derive(Args, Debug)]
pub struct MetricsArgs {
    /// The image to judge (EXR).
    pub image: PathBuf,
    /// The reference (EXR).
    pub reference: PathBuf,
    /// ε of relMSE, MAPE and SMAPE.
    #[arg(long, default_value_t = DEFAULT_REL_EPSILON)]
    pub epsilon: f64,
    /// Fraction of the largest per-pixel errors to drop (e.g. 0.001 for 0.1 % outliers).
    #[arg(long, default_value_t = 0.0)]
    pub outliers: f64,
    /// Exposure (stops) of the tonemapping before LDR-FLIP.
    #[arg(long, default_value_t = 0.0)]
    pub flip_exposure: f32,
    /// A second reference, rendered independently of the first and of the image: also print the
    /// image's relMSE against the true image, with both references' own noise taken out
    /// (mean of (x − a)(x − b)/(m² + ε), m = (a + b)/2; the same outliers dropped).
    #[arg(long, value_name = "EXR")]
    pub second_reference: Option<PathBuf>,
    /// Write the metrics as JSON to PATH instead of a table (`-`, or no PATH: standard output).
    #[arg(long, value_name = "PATH", num_args = 0..=1, default_missing_value = "-")]
    pub json: Option<PathBuf>,
}

/// Runs `focal metrics`.
pub fn run(a: MetricsArgs) -> Result<()> {
    if let Some(p) = &a.json {
        json_out::check(p)?;
    }
    let read = |p: &PathBuf| Image::read_exr(p).with_context(|| format!("reading {}", p.display()));
    let image = read(&a.image)?;
    let reference = read(&a.reference)?;
    let e = image_errors(&image, &reference, a.epsilon, a.outliers).map_err(anyhow::Error::msg)?;
    let (flip, _) = ldr_flip(&image, &reference, a.flip_exposure)?;
    let second = a.second_reference.as_ref().map(read).transpose()?;
    let truth = match &second {
        Some(b) => Some(
            two_reference_rel_mse(&image, &reference, b, a.epsilon, a.outliers)
                .map_err(anyhow::Error::msg)?,
        ),
        None => None,
    };
    let judged = score(&image, &reference, second.as_ref()).map_err(anyhow::Error::msg)?;
    // Two references (the image too carries a variance layer): do they agree within their error bars?
    let agree = match image.layer(VARIANCE_LAYER) {
        Some(_) => Some(agreement(&image, &reference).map_err(anyhow::Error::msg)?),
        None => None,
    };
    if let Some(p) = &a.json {
        let mut v = serde_json::to_value(e)?;
        v["ldr_flip"] = serde_json::json!(flip);
        v["flip_exposure"] = serde_json::json!(a.flip_exposure);
        if let Some(t) = truth {
            v["rel_mse_two_references"] = serde_json::json!(t);
        }
        v["score"] = serde_json::to_value(judged)?;
        if let Some(g) = agree {
            v["agreement"] = serde_json::to_value(g)?;
        }
        return json_out::write(p, &v);
    }
    let mut text = format!(
        "relMSE (eps {}) {:.6e}\nMSE               {:.6e}\nMAPE              {:.6e}\nSMAPE             {:.6e}\nLDR-FLIP (exp {}) {:.6e}\n",
        e.epsilon, e.rel_mse, e.mse, e.mape, e.smape, a.flip_exposure, flip
    );
    if e.outlier_fraction > 0.0 {
        text += &format!(
            "({}% largest per-pixel errors dropped)\n",
            e.outlier_fraction * 100.0
        );
    }
    text += &format!(
        "relMSE, all pixels {:.6e} ({:.1}% of it in the {}% largest per-pixel errors)\n",
        e.rel_mse_all,
        e.rel_mse_top_share * 100.0,
        FIREFLY_PIXEL_FRACTION * 100.0
    );
    if let Some(t) = truth {
        text += &format!("relMSE against the truth, both references' noise removed {t:.6e}\n");
    }
    text +=
        &format!(
        "score: exposure-normalised relMSE {:.6e} (a black image: {:.6e}); image mean {:.4} of \
         the {}'s, {:.4} with the brightest 0.1% of pixels left out{}\n",
        judged.rel_mse,
        judged.black_rel_mse,
        judged.mean_ratio,
        if second.is_some() { "truth" } else { "reference" },
        judged.trimmed_mean_ratio,
        if judged.failed { ": FAILED (off by more than 30%)" } else { "" }
    );
    if let Some(g) = agree {
        text +=
            &format!(
            "agreement of the two references: mean ratio {:.4} ± {:.4} (z {:.2}); {} of {} blocks \
             beyond 3 sigma (largest |z| {:.2}, mean z² {:.2}): {}\n",
            g.mean_ratio,
            g.mean_ratio_sigma,
            g.image_z,
            g.blocks_beyond_limit,
            g.blocks,
            g.max_block_z,
            g.mean_block_z2,
            if g.agree { "they agree" } else { "they DISAGREE" }
        );
    }
    // A closed pipe (`| head`) is the reader's choice, not an error worth a panic.
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    Ok(())
}
