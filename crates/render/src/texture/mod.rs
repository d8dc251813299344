//! Spatially varying parameters of BSDFs: constants, bitmaps (PNG, JPEG, EXR, HDR) and the checkerboard,
//! with Mitsuba 3's conventions (uv (0, 0) is the top-left texel, bilinear filtering, repeat wrapping,
//! 8-bit and 16-bit images sRGB-decoded unless `raw`, float images linear) and Mitsuba 0.6's MIP-mapped
//! `trilinear`/`ewa` filtering over the first hit's pixel footprint.

mod bitmap;
pub mod mipmap;

pub use bitmap::{Bitmap, BitmapFilter};

use crate::color::{srgb_to_linear, Rgb};
use crate::desc::ObjectDesc;
use crate::error::SceneResult;
use glam::{Mat4, Vec2, Vec3};
use std::sync::Arc;

/// A colour- or scalar-valued texture evaluated at surface uv coordinates.
#[derive(Clone, Debug)]
pub enum Texture {
    /// The same value everywhere (`<rgb>`, `<spectrum>`, `<float>` properties).
    Constant(Rgb),
    /// An image (`bitmap`).
    Bitmap(Arc<Bitmap>),
    /// Two alternating colours (`checkerboard`).
    Checkerboard(Arc<Checkerboard>),
}

/// An affine map of uv coordinates (Mitsuba 3 `to_uv`; Mitsuba 0.6 `uscale`/`vscale`/`uoffset`/`voffset`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Row-major 2×3 matrix: u' = m[0]·u + m[1]·v + m[2], v' = m[3]·u + m[4]·v + m[5].
    pub m: [f32; 6],
}

impl UvTransform {
    /// The identity.
    pub const IDENTITY: UvTransform = UvTransform {
        m: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    };

    /// Applies the map.
    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let m = &self.m;
        Vec2::new(
            m[0] * uv.x + m[1] * uv.y + m[2],
            m[3] * uv.x + m[4] * uv.y + m[5],
        )
    }

    /// Maps a uv-space footprint through the linear part of the map.
    #[inline]
    pub fn apply_footprint(&self, fp: &UvFootprint) -> UvFootprint {
        let m = &self.m;
        let lin = |d: Vec2| Vec2::new(m[0] * d.x + m[1] * d.y, m[3] * d.x + m[4] * d.y);
        UvFootprint {
            duv_dx: lin(fp.duv_dx),
            duv_dy: lin(fp.duv_dy),
        }
    }

    /// Reads `to_uv` (the xy part of a transform), or the Mitsuba 0.6 scale/offset parameters.
    pub fn from_desc(o: &ObjectDesc) -> SceneResult<Self> {
        let t: Mat4 = o.transform_or_identity("to_uv")?;
        let mut m = [
            t.x_axis.x, t.y_axis.x, t.w_axis.x, t.x_axis.y, t.y_axis.y, t.w_axis.y,
        ];
        let us = o.float_or("uscale", 1.0)? as f32;
        let vs = o.float_or("vscale", 1.0)? as f32;
        let uo = o.float_or("uoffset", 0.0)? as f32;
        let vo = o.float_or("voffset", 0.0)? as f32;
        // Mitsuba 0.6 applies scale then offset after any other map.
        m[0] *= us;
        m[1] *= us;
        m[2] = m[2] * us + uo;
        m[3] *= vs;
        m[4] *= vs;
        m[5] = m[5] * vs + vo;
        if m.iter().any(|x| !x.is_finite()) {
            return Err(o.error("texture uv transform must be finite"));
        }
        Ok(UvTransform { m })
    }
}

/// How lookups outside [0, 1) are handled (`wrap_mode`, or `wrap_mode_u`/`wrap_mode_v` per axis).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    /// Tile the image (default).
    Repeat,
    /// Tile with every other copy mirrored.
    Mirror,
    /// Use the edge texels.
    Clamp,
    /// Zero outside the image (Mitsuba 0.6 `zero`, also `black`).
    Zero,
    /// One outside the image (Mitsuba 0.6 `one`, also `white`).
    One,
}

impl WrapMode {
    /// Parses a wrap mode name (Mitsuba 0.6 and 3 spellings, case-insensitive).
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name.to_ascii_lowercase().as_str() {
            "repeat" => WrapMode::Repeat,
            "mirror" => WrapMode::Mirror,
            "clamp" => WrapMode::Clamp,
            "zero" | "black" => WrapMode::Zero,
            "one" | "white" => WrapMode::One,
            _ => return None,
        })
    }

    /// The texel index along an axis of `n` texels for integer coordinate `i`, or `None` outside
    /// the image under `zero`/`one`.
    #[inline]
    pub fn fold(self, i: i64, n: i64) -> Option<usize> {
        Some(match self {
            // Most lookups are inside the image: skip the (slow) 64-bit division then.
            WrapMode::Repeat if (0..n).contains(&i) => i,
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let p = i.rem_euclid(2 * n);
                if p < n {
                    p
                } else {
                    2 * n - 1 - p
                }
            }
            WrapMode::Zero | WrapMode::One => {
                if (0..n).contains(&i) {
                    i
                } else {
                    return None;
                }
            }
        } as usize)
    }

    /// A texel-space coordinate brought near the image without changing the lookup (coordinates far
    /// out only lose precision).
    #[inline]
    pub fn reduce(self, x: f64, n: u32) -> f64 {
        match self {
            WrapMode::Repeat | WrapMode::Mirror => x.rem_euclid(4.0 * n as f64),
            WrapMode::Clamp | WrapMode::Zero | WrapMode::One => x.clamp(-2.0, n as f64 + 2.0),
        }
    }

    /// The value outside the image under `zero`/`one` (unused by the other modes).
    #[inline]
    pub fn constant(self) -> Rgb {
        if self == WrapMode::One {
            Rgb::ONE
        } else {
            Rgb::ZERO
        }
    }
}

/// The footprint of a pixel sample in uv space: ∂uv/∂x and ∂uv/∂y over one (scaled) pixel step, from
/// the camera ray's differentials at its first hit; zero elsewhere (finest-level lookups).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvFootprint {
    /// ∂(u, v)/∂x.
    pub duv_dx: Vec2,
    /// ∂(u, v)/∂y.
    pub duv_dy: Vec2,
}

/// Reads an image file as linear RGB texels. Float formats (EXR, HDR) are linear; integer formats are
/// sRGB-decoded unless `raw`.
pub(crate) fn load_image(
    path: &std::path::Path,
    raw: bool,
) -> Result<(u32, u32, Vec<Rgb>), String> {
    let img = load_raw_image(path)?;
    let decode = |v: f32| {
        if img.float || raw {
            v
        } else {
            srgb_to_linear(v)
        }
    };
    let texels = img
        .rgba
        .iter()
        .map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))
        .collect();
    Ok((img.width, img.height, texels))
}

/// An image as stored in its file: channel values in [0, 1] for integer formats (still encoded),
/// linear for float formats; alpha 1 where the file has none.
pub(crate) struct RawImage {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<[f32; 4]>,
    /// A float format (EXR, HDR, float TIFF): values are linear.
    pub float: bool,
}

/// Reads an image file without decoding its transfer function (see [`RawImage`]).
pub(crate) fn load_raw_image(path: &std::path::Path) -> Result<RawImage, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "exr" {
        let img =
            crate::film::Image::read_exr(path).map_err(|e| format!("cannot read image: {e}"))?;
        let rgba = img.rgb.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
        return Ok(RawImage {
            width: img.width,
            height: img.height,
            rgba,
            float: true,
        });
    }
    let img = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open image '{}': {e}", path.display()))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read image '{}': {e}", path.display()))?
        .decode()
        .map_err(|e| format!("cannot decode image '{}': {e}", path.display()))?;
    let float = matches!(
        img.color(),
        image::ColorType::Rgb32F | image::ColorType::Rgba32F
    );
    let rgba = img.to_rgba32f();
    let (width, height) = rgba.dimensions();
    Ok(RawImage {
        width,
        height,
        rgba: rgba.pixels().map(|p| p.0).collect(),
        float,
    })
}

/// Mitsuba's `checkerboard`: `color0` where the fractional parts of u and v are on the same side of ½,
/// `color1` elsewhere.
#[derive(Clone, Debug)]
pub struct Checkerboard {
    /// Colour of the (0, 0) square (Mitsuba default 0.4).
    pub color0: Rgb,
    /// The other colour (default 0.2).
    pub color1: Rgb,
    /// uv transform.
    pub to_uv: UvTransform,
}

impl Checkerboard {
    /// The value at `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let uv = self.to_uv.apply(uv);
        let fu = uv.x - uv.x.floor() > 0.5;
        let fv = uv.y - uv.y.floor() > 0.5;
        if fu == fv {
            self.color0
        } else {
            self.color1
        }
    }
}

impl Texture {
    /// A constant grey value.
    pub fn constant(v: f32) -> Self {
        Texture::Constant(Rgb::splat(v))
    }

    /// The value at `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.eval(uv),
            Texture::Checkerboard(c) => c.eval(uv),
        }
    }

    /// The value at `uv` filtered over the footprint `fp` (only MIP-mapped bitmaps use it).
    #[inline]
    pub fn eval_filtered(&self, uv: Vec2, fp: &UvFootprint) -> Rgb {
        match self {
            Texture::Bitmap(b) => b.eval_filtered(uv, fp),
            _ => self.eval(uv),
        }
    }

    /// True if the texture filters over pixel footprints (a MIP-mapped bitmap).
    pub fn uses_footprint(&self) -> bool {
        matches!(self, Texture::Bitmap(b) if b.is_mipmapped())
    }

    /// The scalar value at `uv` (mean of the channels, as Mitsuba's `eval_1` on RGB textures).
    #[inline]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        let c = self.eval(uv);
        (c.x + c.y + c.z) / 3.0
    }

    /// The gradient (∂/∂u, ∂/∂v) of the scalar value at `uv` (luminance for colour bitmaps, as Mitsuba
    /// 3's `eval_1_grad`), for bump maps; zero where the texture is piecewise constant.
    #[inline]
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap(b) => b.eval_1_grad(uv),
            Texture::Constant(_) | Texture::Checkerboard(_) => Vec2::ZERO,
        }
    }

    /// The largest value anywhere (for bounds and albedo estimates).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Constant(c) => c.max_element(),
            Texture::Bitmap(b) => b.max_value(),
            Texture::Checkerboard(c) => c.color0.max_element().max(c.color1.max_element()),
        }
    }

    /// The mean value over the texture's domain (Mitsuba's `Texture::mean`, for sampling weights).
    pub fn mean(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.mean(),
            Texture::Checkerboard(c) => (c.color0 + c.color1) * 0.5,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_alternates() {
        let c = Checkerboard {
            color0: Rgb::splat(0.4),
            color1: Rgb::splat(0.2),
            to_uv: UvTransform {
                m: [2.0, 0.0, 0.0, 0.0, 2.0, 0.0],
            },
        };
        assert_eq!(c.eval(Vec2::new(0.1, 0.1)), Rgb::splat(0.4));
        assert_eq!(c.eval(Vec2::new(0.3, 0.1)), Rgb::splat(0.2));
        assert_eq!(c.eval(Vec2::new(0.3, 0.3)), Rgb::splat(0.4));
    }
}
