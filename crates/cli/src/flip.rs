//! LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images") of two
//! renders, through `nv-flip`, the bindings to NVIDIA's own C++ implementation. Both images are
//! tonemapped as focal's PNGs are (× 2^exposure, clamped, sRGB) and compared at the default viewing
//! condition (67 pixels per degree: a 0.7 m distant 24" 4K monitor). HDR-FLIP is not in the bindings.

use anyhow::{bail, Result};
use focal_render::color::srgb_to_linear;
use focal_render::film::Image;

/// The mean LDR-FLIP error (0 = indistinguishable, 1 = most different) and the per-pixel error map.
pub fn ldr_flip(
    image: &Image,
    reference: &Image,
    exposure: f32,
) -> Result<(f64, nv_flip::FlipImageFloat)> {
    if (image.width, image.height) != (reference.width, reference.height) {
        bail!(
            "images differ in size: {}x{} and {}x{}",
            image.width,
            image.height,
            reference.width,
            reference.height
        );
    }
    let (w, h) = (image.width, image.height);
    let test = nv_flip::FlipImageRgb8::with_data(w, h, &image.to_srgb8(exposure));
    let refe = nv_flip::FlipImageRgb8::with_data(w, h, &reference.to_srgb8(exposure));
    let map = nv_flip::flip(refe, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mean = nv_flip::FlipPool::from_image(&map).mean() as f64;
    Ok((mean, map))
}

/// The error map in FLIP's magma colour map, as a linear image for `write_png`.
pub fn flip_picture(map: &nv_flip::FlipImageFloat) -> Image {
    let rgb = map.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    let mut out = Image::new(map.width(), map.height());
    for (o, c) in out.rgb.iter_mut().zip(rgb.chunks_exact(3)) {
        *o = [0, 1, 2].map(|k| srgb_to_linear(c[k] as f32 / 255.0));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(v: f32) -> Image {
        let mut img = Image::new(16, 16);
        img.rgb.fill([v; 3]);
        img
    }

    #[test]
    fn identical_images_have_zero_flip_and_black_vs_white_a_large_one() {
        let (same, _) = ldr_flip(&flat(0.5), &flat(0.5), 0.0).unwrap();
        assert_eq!(same, 0.0);
        let (diff, map) = ldr_flip(&flat(0.0), &flat(1.0), 0.0).unwrap();
        assert!(diff > 0.5 && diff <= 1.0, "{diff}");
        assert_eq!((map.width(), map.height()), (16, 16));
        assert!(ldr_flip(&flat(0.0), &Image::new(3, 3), 0.0).is_err());
    }
}
