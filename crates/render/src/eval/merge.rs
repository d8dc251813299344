//! Combining independent renders of the same scene (different seeds, possibly on different machines)
//! into one image: the sample-count weighted mean, so `k` renders of `n_i` spp give the estimate of one
//! render of `Σ n_i` spp.
//!
//! A [`VARIANCE_LAYER`] present in every input is combined as the variance of the weighted mean of
//! independent estimates, `Σ (n_i / N)² Var_i`. Other layers (AOVs) are averaged with
//! the same weights.
//!
//! Where every input has a [`FILTER_WEIGHT_LAYER`] (the shards of one render), pixels are weighted by
//! their filter weights instead, `Σ Wᵢ Iᵢ / Σ Wᵢ`: that is the image of all the inputs' samples, which
//! for shards drawing disjoint sample indices is the image of one render of all of them (to f32
//! rounding). The output's filter weight is `Σ Wᵢ`, so merges of merges stay exact.

use crate::film::{Image, FILTER_WEIGHT_LAYER};
use crate::render::reference::VARIANCE_LAYER;

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
    if first.layer(FILTER_WEIGHT_LAYER).is_some() {
        return Ok(merge_by_filter_weight(inputs));
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

/// [`merge_images`] of inputs with filter weights (checked to have the same size and layers): every
/// pixel weighted by its inputs' filter weights.
fn merge_by_filter_weight(inputs: &[(Image, u64)]) -> Image {
    let first = &inputs[0].0;
    let weight_of = |img: &Image| -> Vec<f64> {
        let layer = img.layer(FILTER_WEIGHT_LAYER).expect("checked");
        layer.data.iter().map(|&w| w as f64).collect()
    };
    let weights: Vec<Vec<f64>> = inputs.iter().map(|(img, _)| weight_of(img)).collect();
    let total: Vec<f64> = (0..first.rgb.len())
        .map(|p| weights.iter().map(|w| w[p]).sum())
        .collect();
    // Each input's share of every pixel (0 where no input has weight).
    let share = |i: usize, p: usize| {
        if total[p] != 0.0 {
            weights[i][p] / total[p]
        } else {
            0.0
        }
    };
    let mut out = first.clone();
    for (p, o) in out.rgb.iter_mut().enumerate() {
        let mut acc = [0.0f64; 3];
        for (i, (img, _)) in inputs.iter().enumerate() {
            for (a, v) in acc.iter_mut().zip(img.rgb[p]) {
                *a += share(i, p) * v as f64;
            }
        }
        *o = acc.map(|v| v as f32);
    }
    for (l, layer) in out.layers.iter_mut().enumerate() {
        let n = layer.channels.len();
        for (k, o) in layer.data.iter_mut().enumerate() {
            let p = k / n;
            *o = if layer.name == FILTER_WEIGHT_LAYER {
                total[p] as f32
            } else {
                let variance = layer.name == VARIANCE_LAYER;
                let mut acc = 0.0f64;
                for (i, (img, _)) in inputs.iter().enumerate() {
                    let s = share(i, p);
                    let w = if variance { s * s } else { s };
                    acc += w * img.layers[l].data[k] as f64;
                }
                acc as f32
            };
        }
    }
    out.sanitize();
    out
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
    fn filter_weights_give_the_image_of_all_samples() {
        // Pixel sums Σw·L = 2 over Σw = 1, and 9 over Σw = 3: all samples give 11 / 4.
        let shard = |v: f32, w: f32| {
            let mut img = one_pixel([v; 3], None);
            let mut l = ImageLayer::new(FILTER_WEIGHT_LAYER, &["W"], 1, 1);
            l.data[0] = w;
            img.layers.push(l);
            img
        };
        let m = merge_images(&[(shard(2.0, 1.0), 2), (shard(3.0, 3.0), 2)]).unwrap();
        assert_eq!(m.rgb[0], [2.75; 3]);
        assert_eq!(m.layer(FILTER_WEIGHT_LAYER).unwrap().data[0], 4.0);
        // No weight anywhere: black, not NaN.
        let m = merge_images(&[(shard(2.0, 0.0), 1), (shard(3.0, 0.0), 1)]).unwrap();
        assert_eq!(m.rgb[0], [0.0; 3]);
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
