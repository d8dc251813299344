//! Do two references agree within their error bars?
//!
//! A scene's truth comes from two long references made independently (different methods and seeds).
//! Each carries a per-pixel variance of its mean (`focal reference` writes it from batch means over its
//! passes). If both are unbiased, their difference over any region is zero within the square root of
//! the sum of their variances there. This module compares the references' mean brightness over the
//! whole image and over blocks of pixels, as z-scores: a block far outside its error bars points at a
//! biased method, or at a reference whose heavy-tailed noise its own variance estimate misses.
//!
//! A channel's variances are combined into the brightness variance as if the channels were fully
//! correlated (((σ_R + σ_G + σ_B)/3)², an upper bound): the samples of one path carry all three. An image
//! without a variance layer (a Mitsuba render) counts as exact.

use crate::eval::metrics::finite;
use crate::film::Image;

/// The name of the per-pixel variance-of-the-mean layer (as `focal reference` writes it).
pub use crate::render::reference::VARIANCE_LAYER;

/// Block edge in pixels of [`agreement`]'s regional comparison.
pub const BLOCK: u32 = 20;
/// A block, or the whole image, disagrees beyond this many standard deviations.
pub const Z_LIMIT: f64 = 3.0;

/// How two references compare.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Agreement {
    /// Mean brightness of the first over the second.
    pub mean_ratio: f64,
    /// Standard deviation of that ratio (from both variance layers).
    pub mean_ratio_sigma: f64,
    /// z-score of the difference of the whole images' mean brightness.
    pub image_z: f64,
    /// Blocks of [`BLOCK`]² pixels compared (those with light in either image).
    pub blocks: usize,
    /// Blocks whose difference is beyond [`Z_LIMIT`] standard deviations.
    pub blocks_beyond_limit: usize,
    /// The largest |z| of a block.
    pub max_block_z: f64,
    /// Mean z² over the blocks: about 1 when the error bars are right.
    pub mean_block_z2: f64,
    /// Whether each image had a variance layer.
    pub has_variance: [bool; 2],
    /// Within the error bars: |image z| and every block within [`Z_LIMIT`], but for 1 % of the blocks
    /// (under normal noise 0.27 % of them fall beyond 3 σ by chance).
    pub agree: bool,
}

/// Per-pixel brightness and its variance (0 without a variance layer).
fn brightness_and_variance(image: &Image) -> (Vec<f64>, Vec<f64>, bool) {
    let b: Vec<f64> = image
        .rgb
        .iter()
        .map(|p| (finite(p[0]) + finite(p[1]) + finite(p[2])) / 3.0)
        .collect();
    match image
        .layer(VARIANCE_LAYER)
        .filter(|l| l.channels.len() == 3)
    {
        Some(l) => {
            let v = l
                .data
                .chunks_exact(3)
                .map(|c| {
                    let s: f64 = c.iter().map(|&x| finite(x).max(0.0).sqrt()).sum::<f64>() / 3.0;
                    s * s
                })
                .collect();
            (b, v, true)
        }
        None => (b, vec![0.0; image.rgb.len()], false),
    }
}

/// Compares the references `a` and `b` (same size) over the whole image and over blocks.
pub fn agreement(a: &Image, b: &Image) -> Result<Agreement, String> {
    if a.width != b.width || a.height != b.height {
        return Err(format!(
            "the references differ in size: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        ));
    }
    let (ba, va, ha) = brightness_and_variance(a);
    let (bb, vb, hb) = brightness_and_variance(b);
    let n = ba.len().max(1) as f64;
    let (ma, mb) = (ba.iter().sum::<f64>() / n, bb.iter().sum::<f64>() / n);
    let (sa, sb) = (
        va.iter().sum::<f64>() / (n * n),
        vb.iter().sum::<f64>() / (n * n),
    );
    let z = |d: f64, v: f64| {
        if v > 0.0 {
            d / v.sqrt()
        } else if d == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    };
    let image_z = z(ma - mb, sa + sb);
    let mean_ratio = if mb > 0.0 { ma / mb } else { f64::NAN };
    // Var(ma/mb) ≈ (ma/mb)² (Var ma / ma² + Var mb / mb²).
    let mean_ratio_sigma = mean_ratio.abs() * (sa / (ma * ma) + sb / (mb * mb)).sqrt();
    let (w, h) = (a.width as usize, a.height as usize);
    let bs = BLOCK as usize;
    let mut zs = Vec::new();
    for by in (0..h).step_by(bs) {
        for bx in (0..w).step_by(bs) {
            let (mut d, mut v, mut light) = (0.0, 0.0, false);
            for y in by..(by + bs).min(h) {
                for x in bx..(bx + bs).min(w) {
                    let i = y * w + x;
                    d += ba[i] - bb[i];
                    v += va[i] + vb[i];
                    light |= ba[i] > 0.0 || bb[i] > 0.0;
                }
            }
            if light {
                zs.push(z(d, v));
            }
        }
    }
    let beyond = zs.iter().filter(|z| !(z.abs() <= Z_LIMIT)).count();
    let max_block_z = zs.iter().fold(0.0f64, |m, z| m.max(z.abs()));
    let mean_block_z2 = zs.iter().map(|z| z * z).sum::<f64>() / zs.len().max(1) as f64;
    let allowed = zs.len() / 100;
    Ok(Agreement {
        mean_ratio,
        mean_ratio_sigma,
        image_z,
        blocks: zs.len(),
        blocks_beyond_limit: beyond,
        max_block_z,
        mean_block_z2,
        has_variance: [ha, hb],
        agree: image_z.abs() <= Z_LIMIT && beyond <= allowed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::ImageLayer;
    use focal_testkit::TestRng;

    /// A 100x60 reference of `level` with per-pixel noise of standard deviation `sigma` per channel and
    /// that variance in its layer.
    fn reference(level: f64, sigma: f64, rng: &mut TestRng) -> Image {
        let (w, h) = (100, 60);
        let mut img = Image::new(w, h);
        let mut layer = ImageLayer::new(VARIANCE_LAYER, &["R", "G", "B"], w, h);
        for (i, p) in img.rgb.iter_mut().enumerate() {
            let v = (level + sigma * rng.next_normal()) as f32;
            *p = [v; 3];
            layer.data[3 * i..3 * i + 3].fill((sigma * sigma) as f32);
        }
        img.layers.push(layer);
        img
    }

    #[test]
    fn independent_references_of_one_image_agree() {
        let mut rng = TestRng::new(1);
        let a = reference(1.0, 0.2, &mut rng);
        let b = reference(1.0, 0.2, &mut rng);
        let g = agreement(&a, &b).unwrap();
        assert!(g.agree, "{g:?}");
        assert_eq!(g.blocks, 5 * 3);
        assert!(
            (g.mean_ratio - 1.0).abs() < 4.0 * g.mean_ratio_sigma,
            "{g:?}"
        );
        assert!(g.mean_block_z2 > 0.3 && g.mean_block_z2 < 3.0, "{g:?}");
    }

    #[test]
    fn a_biased_region_is_found() {
        let mut rng = TestRng::new(2);
        let a = reference(1.0, 0.2, &mut rng);
        let mut b = reference(1.0, 0.2, &mut rng);
        // 20 % too dark in one block: 400 pixels of σ 0.2·√2 give a block σ of 0.014 on a mean of 1.
        for y in 0..20 {
            for x in 0..20 {
                b.rgb[y * 100 + x] = b.rgb[y * 100 + x].map(|c| c * 0.8);
            }
        }
        let g = agreement(&a, &b).unwrap();
        assert!(!g.agree, "{g:?}");
        assert_eq!(g.blocks_beyond_limit, 1);
        assert!(g.max_block_z > 10.0, "{g:?}");
    }

    #[test]
    fn without_variance_an_exact_image_must_match_exactly() {
        let mut rng = TestRng::new(3);
        let a = reference(1.0, 0.2, &mut rng);
        let mut exact = Image::new(100, 60);
        exact.rgb.iter_mut().for_each(|p| *p = [1.0; 3]);
        let g = agreement(&a, &exact).unwrap();
        assert_eq!(g.has_variance, [true, false]);
        assert!(g.agree, "{g:?}");
        assert!(agreement(&a, &Image::new(3, 3)).is_err());
    }
}
