//! Per-pixel weights for training segments, so that what the guide and the selection learn from
//! second moments weighs every pixel's relative error alike (relMSE), not only the bright pixels'.

use super::combine::IterationImage;

/// Weights Ī²/(Ĩ² + Ī²) per crop-window pixel, row-major: Ĩ is the pixel's RGB mean over all samples of
/// the iterations so far, box-filtered over 3×3 pixels (a few samples per pixel are noisy), and Ī the
/// image mean, which sets the scale below which pixels count as dark (so the weights do not depend on
/// the scene's exposure; 1 for a dark pixel, 1/2 for an average one, small for highlights). `None`
/// before any sample, or if the image is black or not finite.
pub fn relative_pixel_weights(
    images: &[IterationImage],
    width: u32,
    height: u32,
) -> Option<Vec<f32>> {
    let n = width as usize * height as usize;
    let mut sum = vec![0.0f64; n];
    let mut spp = 0u64;
    for image in images {
        for (img, s) in [&image.a, &image.b] {
            if *s == 0 || img.rgb.len() != n {
                continue;
            }
            for (acc, p) in sum.iter_mut().zip(&img.rgb) {
                *acc += *s as f64 * (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0;
            }
            spp += *s as u64;
        }
    }
    if spp == 0 {
        return None;
    }
    let (w, h) = (width as usize, height as usize);
    let mut filtered = vec![0.0f64; n];
    for y in 0..h {
        for x in 0..w {
            let (mut acc, mut count) = (0.0, 0.0);
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    acc += sum[yy * w + xx];
                    count += 1.0;
                }
            }
            filtered[y * w + x] = acc / count / spp as f64;
        }
    }
    let mean = filtered.iter().sum::<f64>() / n as f64;
    if !(mean > 0.0 && mean.is_finite()) {
        return None;
    }
    let scale = mean * mean;
    Some(
        filtered
            .iter()
            .map(|&i| {
                let i = i.max(0.0);
                (scale / (i * i + scale)) as f32
            })
            .collect(),
    )
}
