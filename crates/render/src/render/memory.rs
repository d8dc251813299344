//! The memory a render's images take, so that a front end can refuse a film that does not fit before
//! allocating it (an allocation failure aborts the process; a 65536² film needs 128 GiB of
//! accumulators alone).

use crate::film::FilmSpec;

/// Bytes per pixel of a film's accumulators: Σw·RGB and Σw in f64, and Σw·AOV (7 channels) with AOVs.
fn film_bytes_per_pixel(aovs: bool) -> u64 {
    8 * (4 + if aovs { 7 } else { 0 })
}

/// Bytes per pixel of a developed image: RGB in f32, and the AOV layers (7 channels) with AOVs.
fn image_bytes_per_pixel(aovs: bool) -> u64 {
    4 * (3 + if aovs { 7 } else { 0 })
}

/// Pixels of the rendered window.
fn pixels(spec: &FilmSpec) -> u64 {
    spec.crop_size.x as u64 * spec.crop_size.y as u64
}

/// Memory of a plain render's images: one film, and the few developed copies the output goes through
/// (developed, sanitised, tonemapped for PNG).
pub fn plain_render_bytes(spec: &FilmSpec, aovs: bool) -> u64 {
    pixels(spec) * (film_bytes_per_pixel(aovs) + 3 * image_bytes_per_pixel(aovs))
}

/// Memory of a guided render's images with `iterations` training iterations: two half films, the two
/// developed halves every iteration keeps for the combination, and the output's copies.
pub fn guided_render_bytes(spec: &FilmSpec, aovs: bool, iterations: u32) -> u64 {
    let kept = 2 * (iterations as u64 + 1) + 3;
    pixels(spec) * (2 * film_bytes_per_pixel(aovs) + kept * image_bytes_per_pixel(aovs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::UVec2;

    #[test]
    fn a_65536_square_film_needs_over_128_gib() {
        let spec = FilmSpec {
            width: 65536,
            height: 65536,
            crop_size: UVec2::splat(65536),
            ..FilmSpec::default()
        };
        assert!(plain_render_bytes(&spec, false) > 128 << 30);
        assert!(guided_render_bytes(&spec, false, 15) > plain_render_bytes(&spec, false));
        let small = FilmSpec {
            width: 256,
            height: 256,
            crop_size: UVec2::splat(256),
            ..FilmSpec::default()
        };
        assert!(plain_render_bytes(&small, true) < 64 << 20);
    }
}
