//! Linear RGB radiometric quantities.

/// Linear RGB triple used for radiance, reflectance and throughput (Mitsuba's `*_rgb` variants).
pub type Rgb = glam::Vec3;

/// Luminance of a linear sRGB/Rec.709 colour.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// True if every channel is exactly zero.
#[inline]
pub fn is_black(c: Rgb) -> bool {
    c.x == 0.0 && c.y == 0.0 && c.z == 0.0
}

/// Converts one sRGB-encoded channel to linear (used by `<srgb>` properties and 8-bit textures).
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Converts one linear channel to sRGB encoding (used when writing PNGs).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}
