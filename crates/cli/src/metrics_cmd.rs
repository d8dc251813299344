//! `focal metrics`: error metrics between two images.

use anyhow::{Context, Result};
use clap::Args;
use focal_render::film::Image;
use focal_render::metrics::{image_errors, DEFAULT_REL_EPSILON};
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
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `focal metrics`.
pub fn run(a: MetricsArgs) -> Result<()> {
    let read = |p: &PathBuf| Image::read_exr(p).with_context(|| format!("reading {}", p.display()));
    let image = read(&a.image)?;
    let reference = read(&a.reference)?;
    let e = image_errors(&image, &reference, a.epsilon, a.outliers).map_err(anyhow::Error::msg)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&e)?);
    } else {
        println!("relMSE (eps {}) {:.6e}", e.epsilon, e.rel_mse);
        println!("MSE               {:.6e}", e.mse);
        println!("MAPE              {:.6e}", e.mape);
        println!("SMAPE             {:.6e}", e.smape);
        if e.outlier_fraction > 0.0 {
            println!(
                "({}% largest per-pixel errors dropped)",
                e.outlier_fraction * 100.0
            );
        }
    }
    Ok(())
}
