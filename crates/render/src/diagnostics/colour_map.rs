//! Colour maps of the diagnostic pictures.

use crate::color::srgb_to_linear;
use crate::film::Image;

/// A false-colour version of a non-negative scalar image on a log scale spanning `decades` below its
/// maximum (viridis-like: dark blue = low, yellow = high), as linear RGB ready for `write_png`.
pub fn false_colour_log(values: &Image, decades: f32) -> Image {
    let max = values
        .rgb
        .iter()
        .map(|p| p[0])
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    let mut out = Image::new(values.width, values.height);
    for (o, v) in out.rgb.iter_mut().zip(&values.rgb) {
        let t = if max > 0.0 && v[0] > 0.0 {
            ((v[0] / max).log10() / decades + 1.0).clamp(0.0, 1.0)
        } else {
            0.0
        };
        *o = viridis(t).map(srgb_to_linear);
    }
    out
}

/// A perceptually ordered dark-blue → green → yellow map (viridis control points), sRGB-encoded.
pub fn viridis(t: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 5] = [
        [0.267, 0.005, 0.329],
        [0.230, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    std::array::from_fn(|c| STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f)
}
