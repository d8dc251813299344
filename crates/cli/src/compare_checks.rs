//! What `focal compare` checks before it renders anything (so a mistake leaves no half-written folder),
//! and its judgement of the reference's own noise once the runs are in.

use crate::compare_args::CompareArgs;
use crate::input_checks;
use crate::render_cmd::{parse_defines, parse_res};
use anyhow::{bail, Context, Result};
use focal_render::film::Image;
use focal_render::load::load_scene;
use focal_render::render::reference::VARIANCE_LAYER;
use focal_render::scene::BuildOptions;
use std::path::Path;

/// The methods `compare` knows.
pub const METHODS: [&str; 4] = ["pt", "none", "octree", "gmm"];

/// What the checks read and `compare` then uses.
pub struct CompareInputs {
    /// The methods, in the order given.
    pub methods: Vec<String>,
    /// The reference image.
    pub reference: Image,
    /// The second reference, if any.
    pub second_reference: Option<Image>,
}

/// Checks every argument, the references and their size against the scene's film, and that the output
/// folder can be written, before anything is rendered or created.
pub fn check_compare_args(a: &CompareArgs) -> Result<CompareInputs> {
    if a.time.is_none() && a.spp.is_none() {
        bail!("give a budget: --time SECONDS (equal time) or --spp N (equal samples)");
    }
    if let Some(t) = a.time {
        input_checks::time_budget("--time", t)?;
    }
    if a.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    input_checks::threads(a.threads)?;
    if a.seeds == 0 {
        bail!("--seeds must be at least 1");
    }
    if a.curve_points == 0 {
        bail!("--curve-points must be at least 1");
    }
    if a.curve_points > 20 {
        bail!(
            "--curve-points {} halves the budget more than 19 times",
            a.curve_points
        );
    }
    if !(a.epsilon > 0.0) || !a.epsilon.is_finite() {
        bail!("--epsilon must be a positive number, got {}", a.epsilon);
    }
    if !(0.0..1.0).contains(&a.outliers) {
        bail!("--outliers must lie in [0, 1), got {}", a.outliers);
    }
    if !matches!(a.combine.as_str(), "variance" | "inverse-variance" | "last") {
        bail!("unknown --combine '{}' (variance or last)", a.combine);
    }
    let methods: Vec<String> = a.methods.split(',').map(|m| m.trim().to_string()).collect();
    for (i, m) in methods.iter().enumerate() {
        if !METHODS.contains(&m.as_str()) {
            bail!(
                "unknown method '{m}' in --methods (known: {})",
                METHODS.join(", ")
            );
        }
        if methods[..i].contains(m) {
            bail!("--methods names '{m}' twice");
        }
    }
    input_checks::output_folder("-o", &a.out)?;
    let read = |p: &Path| Image::read_exr(p).with_context(|| format!("reading {}", p.display()));
    let reference = read(&a.reference)?;
    let second_reference = a.second_reference.as_deref().map(read).transpose()?;
    // The scene's film decides the runs' size: a reference of another size would fail every judgement.
    let params = parse_defines(&a.defines)?;
    let opts = BuildOptions {
        film_size: a.res.as_deref().map(parse_res).transpose()?,
        ..BuildOptions::default()
    };
    let loaded = load_scene(&a.scene, &params, &opts)?;
    let (w, h) = (loaded.film.crop_size.x, loaded.film.crop_size.y);
    let references = std::iter::once((&a.reference, &reference))
        .chain(a.second_reference.as_ref().zip(second_reference.as_ref()));
    for (path, image) in references {
        if (image.width, image.height) != (w, h) {
            bail!(
                "{} is {}x{}, but {} renders {w}x{h} with these parameters",
                path.display(),
                image.width,
                image.height,
                a.scene.display()
            );
        }
    }
    Ok(CompareInputs {
        methods,
        reference,
        second_reference,
    })
}

/// The reference's own relMSE (its expected squared error against the truth, relative as relMSE with
/// `epsilon`), from its per-pixel variance of the mean ([`VARIANCE_LAYER`], as `focal reference`
/// writes); `None` without that layer.
pub fn reference_rel_variance(reference: &Image, epsilon: f64) -> Option<f64> {
    let layer = reference.layer(VARIANCE_LAYER)?;
    if layer.channels.len() != 3 {
        return None;
    }
    let mut sum = 0.0f64;
    for (r, v) in reference.rgb.iter().zip(layer.data.chunks_exact(3)) {
        for c in 0..3 {
            let (r, v) = (r[c] as f64, v[c] as f64);
            if r.is_finite() && v.is_finite() {
                sum += v.max(0.0) / (r * r + epsilon);
            }
        }
    }
    Some(sum / (3 * reference.rgb.len().max(1)) as f64)
}

/// A warning when the reference is noisier than the runs it judges: a run's measured relMSE is its own
/// error plus the reference's, so where the reference's (`reference_rel_mse`, from its variance layer)
/// is more than half the lowest measured mean, that run's own error is below the reference's noise.
/// Without a variance layer, the sample counts tell for the path tracer (the reference's estimator):
/// a reference with no more samples per pixel than its runs is at least as noisy.
pub fn reference_noise_warning(
    reference_rel_mse: Option<f64>,
    reference_spp: Option<u64>,
    lowest: Option<(&str, f64)>,
    pt_spp: Option<f64>,
) -> Option<String> {
    const HINT: &str = "render a longer reference (focal reference), or give --second-reference \
                        to take both references' noise out";
    match (reference_rel_mse, lowest, reference_spp, pt_spp) {
        (Some(r), Some((method, m)), ..) if r > 0.5 * m => Some(format!(
            "the reference is noisier than the runs it judges: its own relMSE, from its variance \
             layer, is {r:.3e}, against {m:.3e} measured for {method} (which includes it); {HINT}"
        )),
        (None, _, Some(n), Some(pt)) if (n as f64) <= pt => Some(format!(
            "the reference has {n} spp, no more than the path tracer's runs ({pt:.0} spp): it is \
             at least as noisy as they are; {HINT}"
        )),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use focal_render::film::ImageLayer;

    #[test]
    fn reference_variance_is_relative_like_rel_mse() {
        let mut img = Image::new(1, 1);
        img.rgb[0] = [1.0, 0.0, 3.0];
        let mut l = ImageLayer::new(VARIANCE_LAYER, &["R", "G", "B"], 1, 1);
        l.data.copy_from_slice(&[0.5, 0.01, 9.0]);
        img.layers.push(l);
        let v = reference_rel_variance(&img, 0.0 + 1e-2).unwrap();
        let want = (0.5 / 1.01 + 0.01 / 0.01 + 9.0 / 9.01) / 3.0;
        assert!((v - want).abs() < 1e-6, "{v} vs {want}");
        assert_eq!(reference_rel_variance(&Image::new(1, 1), 1e-2), None);
    }

    #[test]
    fn warns_only_when_the_reference_noise_dominates() {
        assert!(reference_noise_warning(Some(0.6), None, Some(("gmm", 1.0)), None).is_some());
        assert!(reference_noise_warning(Some(0.4), None, Some(("gmm", 1.0)), None).is_none());
        assert!(reference_noise_warning(None, Some(64), None, Some(64.0)).is_some());
        assert!(reference_noise_warning(None, Some(4096), None, Some(64.0)).is_none());
        assert!(reference_noise_warning(None, None, Some(("pt", 1.0)), Some(64.0)).is_none());
    }
}
