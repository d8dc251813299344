//! Combining independent renders of the same scene (different seeds, possibly on different machines)
//! into one image: the sample-count weighted mean, so `k` renders of `n_i` spp give the estimate of one
//! render of `Σ n_i` spp.
//!
//! A [`super::reference::VARIANCE_LAYER`] present in every input is combined as the variance of the
//! weighted mean of independent estimates, `Σ (n_i / N)² Var_i`. Other layers (AOVs) are averaged with
//! the same weights.

use super::reference::VARIANCE_LAYER;
use crate::film::Image;

/// The sample-count weighted mean of `inputs` (image, spp). Errors: no input, a zero sample count,
/// different sizes, or layers that differ between inputs.
pub fn merge_images(inputs: &[(Image, u64)]) -> Result<Image, String> {
    let Some((first, _)) = inputs.first() else {
        return Err("nothing to merge".to_string());
    };
    let total: u64 = inputs.iter().map(|(_, n)| *n).sum();
    for (i, (img, n)) in inputs.iter().enumerate() {
        if *n == 0 {
            return Err(format!("input {} has a sample count of 0", i + 1));
        }
        if (img.width, img.height) != (first.width, first.height) {
            return Err(format!(
                "input {} is {}x{} but input 1 is {}x{}",
                i + 1,
                img.width,
                img.height,
                first.width,
                first.height
            ));
        }
        let names = |im: &Image| -> Vec<(String, Vec<String>)> {
            im.layers
                .iter()
                .map(|l| (l.name.clone(), l.channels.clone()))
                .collect()
        };
        if names(img) != names(first) {
            return Err(format!(
                "input {} has other layers than input 1 ({:?} vs {:?})",
                i + 1,
                names(img),
                names(first)
            ));
        }
    }
    let mut rgb = vec![[0.0f64; 3]; first.rgb.len()];
    let mut layers: Vec<Vec<f64>> = first
        .layers
        .iter()
        .map(|l| vec![0.0; l.data.len()])
        .collect();
    for (img, n) in inputs {
        let w = *n as f64 / total as f64;
        for (a, p) in rgb.iter_mut().zip(&img.rgb) {
            for c in 0..3 {
                a[c] += w * p[c] as f64;
            }
        }
        for (acc, layer) in layers.iter_mut().zip(&img.layers) {
            // Variances of independent estimates add with squared weights.
            let lw = if layer.name == VARIANCE_LAYER {
                w * w
            } else {
                w
            };
            for (a, v) in acc.iter_mut().zip(&layer.data) {
                *a += lw * *v as f64;
            }
        }
    }
    let mut out = first.clone();
    for (o, a) in out.rgb.iter_mut().zip(&rgb) {
        *o = a.map(|v| v as f32);
    }
    for (lo, acc) in out.layers.iter_mut().zip(&layers) {
        for (o, a) in lo.data.iter_mut().zip(acc) {
            *o = *a as f32;
        }
    }
    out.sanitize();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::ImageLayer;

    fn one_pixel(v: [f32; 3], var: Option<f32>) -> Image {
        let mut img = Image::new(1, 1);
        img.rgb[0] = v;
        if let Some(var) = var {
            let mut l = ImageLayer::new(VARIANCE_LAYER, &["R", "G", "B"], 1, 1);
            l.data.fill(var);
            img.layers.push(l);
        }
        img
    }

    #[test]
    fn weighted_by_sample_count() {
        // 1 spp of 4 and 3 spp of 0 → (1·4 + 3·0)/4 = 1; variances 8 and 4/3:
        // (1/4)²·8 + (3/4)²·(4/3) = 0.5 + 0.75 = 1.25.
        let a = one_pixel([4.0, 2.0, 0.0], Some(8.0));
        let b = one_pixel([0.0, 2.0, 4.0], Some(4.0 / 3.0));
        let m = merge_images(&[(a, 1), (b, 3)]).unwrap();
        assert_eq!(m.rgb[0], [1.0, 2.0, 3.0]);
        assert!((m.layers[0].data[0] - 1.25).abs() < 1e-6);
    }

    #[test]
    fn mismatches_are_errors() {
        let a = one_pixel([1.0; 3], None);
        let b = Image::new(2, 1);
        assert!(merge_images(&[(a.clone(), 1), (b, 1)])
            .unwrap_err()
            .contains("2x1"));
        assert!(merge_images(&[(a.clone(), 0)]).is_err());
        assert!(merge_images(&[(a, 1), (one_pixel([1.0; 3], Some(1.0)), 1)]).is_err());
        assert!(merge_images(&[]).is_err());
    }
}
