//! Spatially varying parameters of BSDFs: constants, bitmaps (PNG, JPEG, EXR, HDR) and the checkerboard,
//! with Mitsuba 3's conventions (uv (0, 0) is the top-left texel, bilinear filtering, repeat wrapping,
//! 8-bit and 16-bit images sRGB-decoded unless `raw`, float images linear).

use crate::color::{srgb_to_linear, Rgb};
use crate::desc::ObjectDesc;
use crate::error::{SceneError, SceneResult};
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

/// How lookups outside [0, 1) are handled (`wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    /// Tile the image (default).
    Repeat,
    /// Tile with every other copy mirrored.
    Mirror,
    /// Use the edge texels.
    Clamp,
}

/// An RGB image sampled at uv coordinates.
#[derive(Clone, Debug)]
pub struct Bitmap {
    width: u32,
    height: u32,
    /// Linear RGB, row-major from the top row.
    texels: Vec<Rgb>,
    bilinear: bool,
    wrap: WrapMode,
    to_uv: UvTransform,
    max: f32,
    mean: Rgb,
}

impl Bitmap {
    /// A bitmap from linear texels (row-major, top row first). `None` if the size does not match.
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<Rgb>,
        bilinear: bool,
        wrap: WrapMode,
        to_uv: UvTransform,
    ) -> Option<Self> {
        if width == 0 || height == 0 || texels.len() != width as usize * height as usize {
            return None;
        }
        let max = texels.iter().map(|t| t.max_element()).fold(0.0, f32::max);
        let mean = texels.iter().fold(Vec3::ZERO, |a, t| a + *t) / texels.len() as f32;
        Some(Bitmap {
            width,
            height,
            texels,
            bilinear,
            wrap,
            to_uv,
            max,
            mean,
        })
    }

    /// Loads a `bitmap` texture element: `filename` (PNG, JPEG, EXR or HDR), `raw` (skip sRGB decoding
    /// of integer images), `filter_type` (bilinear | nearest), `wrap_mode` (repeat | mirror | clamp) and
    /// the uv transform.
    pub fn from_desc(o: &ObjectDesc) -> SceneResult<Self> {
        Self::from_desc_raw(o, o.bool_or("raw", false)?)
    }

    /// As [`Bitmap::from_desc`] with `raw` given (the normal map always reads its image raw).
    pub fn from_desc_raw(o: &ObjectDesc, raw: bool) -> SceneResult<Self> {
        let (path, loc) = o
            .resolve_path("filename")?
            .ok_or_else(|| o.error(format!("'{}' needs a 'filename'", o.plugin)))?;
        let (w, h, texels) = load_image(&path, raw).map_err(|e| SceneError::at(&loc, e))?;
        if let Some(i) = texels.iter().position(|t| !t.is_finite()) {
            return Err(SceneError::at(
                &loc,
                format!(
                    "image '{}' has a non-finite texel at ({}, {})",
                    path.display(),
                    i % w as usize,
                    i / w as usize
                ),
            ));
        }
        let bilinear = match o.string_or("filter_type", "bilinear")?.as_str() {
            "bilinear" => true,
            "nearest" => false,
            other => {
                return Err(o.error(format!(
                    "invalid filter_type '{other}' (bilinear or nearest)"
                )))
            }
        };
        let wrap = match o.string_or("wrap_mode", "repeat")?.as_str() {
            "repeat" => WrapMode::Repeat,
            "mirror" => WrapMode::Mirror,
            "clamp" => WrapMode::Clamp,
            other => {
                return Err(o.error(format!(
                    "invalid wrap_mode '{other}' (repeat, mirror or clamp)"
                )))
            }
        };
        Bitmap::new(w, h, texels, bilinear, wrap, UvTransform::from_desc(o)?)
            .ok_or_else(|| SceneError::at(&loc, format!("image '{}' is empty", path.display())))
    }

    fn texel(&self, x: i64, y: i64) -> Rgb {
        let fold = |i: i64, n: i64| -> usize {
            (match self.wrap {
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
            }) as usize
        };
        let (w, h) = (self.width as i64, self.height as i64);
        self.texels[fold(y, h) * self.width as usize + fold(x, w)]
    }

    /// The filtered value at `uv`.
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let uv = self.to_uv.apply(uv);
        if !uv.is_finite() {
            return Rgb::ZERO;
        }
        let x = uv.x as f64 * self.width as f64;
        let y = uv.y as f64 * self.height as f64;
        // Coordinates this far out only lose precision; wrap them first.
        let (x, y) = (
            x.rem_euclid(4.0 * self.width as f64),
            y.rem_euclid(4.0 * self.height as f64),
        );
        if !self.bilinear {
            return self.texel(x.floor() as i64, y.floor() as i64);
        }
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0) * (1.0 - tx) + self.texel(x0 + 1, y0) * tx;
        let bottom = self.texel(x0, y0 + 1) * (1.0 - tx) + self.texel(x0 + 1, y0 + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}

/// Reads an image file as linear RGB texels. Float formats (EXR, HDR) are linear; integer formats are
/// sRGB-decoded unless `raw`.
pub(crate) fn load_image(
    path: &std::path::Path,
    raw: bool,
) -> Result<(u32, u32, Vec<Rgb>), String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "exr" {
        let img =
            crate::film::Image::read_exr(path).map_err(|e| format!("cannot read image: {e}"))?;
        let texels = img.rgb.iter().map(|p| Vec3::from_array(*p)).collect();
        return Ok((img.width, img.height, texels));
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
    let rgb = img.to_rgb32f();
    let (w, h) = rgb.dimensions();
    let decode = |v: f32| if float || raw { v } else { srgb_to_linear(v) };
    let texels = rgb
        .pixels()
        .map(|p| Vec3::new(decode(p.0[0]), decode(p.0[1]), decode(p.0[2])))
        .collect();
    Ok((w, h, texels))
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

    /// The scalar value at `uv` (mean of the channels, as Mitsuba's `eval_1` on RGB textures).
    #[inline]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        let c = self.eval(uv);
        (c.x + c.y + c.z) / 3.0
    }

    /// The largest value anywhere (for bounds and albedo estimates).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Constant(c) => c.max_element(),
            Texture::Bitmap(b) => b.max,
            Texture::Checkerboard(c) => c.color0.max_element().max(c.color1.max_element()),
        }
    }

    /// The mean value over the texture's domain (Mitsuba's `Texture::mean`, for sampling weights).
    pub fn mean(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.mean,
            Texture::Checkerboard(c) => (c.color0 + c.color1) * 0.5,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bitmap(bilinear: bool, wrap: WrapMode) -> Bitmap {
        // 2×1: black on the left, white on the right.
        Bitmap::new(
            2,
            1,
            vec![Rgb::ZERO, Rgb::ONE],
            bilinear,
            wrap,
            UvTransform::IDENTITY,
        )
        .unwrap()
    }

    #[test]
    fn bilinear_lookups_interpolate_between_texel_centres() {
        let b = bitmap(true, WrapMode::Clamp);
        assert_eq!(b.eval(Vec2::new(0.25, 0.5)), Rgb::ZERO);
        assert_eq!(b.eval(Vec2::new(0.75, 0.5)), Rgb::ONE);
        assert!((b.eval(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        // Repeat wraps the right edge back to the left texel.
        let r = bitmap(true, WrapMode::Repeat);
        assert!((r.eval(Vec2::new(1.0, 0.5)).x - 0.5).abs() < 1e-6);
        assert!((r.eval(Vec2::new(-0.25, 0.5)).x - 1.0).abs() < 1e-6);
        let n = bitmap(false, WrapMode::Repeat);
        assert_eq!(n.eval(Vec2::new(0.49, 0.0)), Rgb::ZERO);
        assert_eq!(n.eval(Vec2::new(0.51, 0.0)), Rgb::ONE);
        assert!(n.eval(Vec2::new(f32::NAN, 0.0)).is_finite());
    }

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
