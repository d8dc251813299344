//! The `bitmap` texture: an image looked up at uv coordinates with Mitsuba 3's `nearest`/`bilinear`
//! filters or, MIP-mapped, Mitsuba 0.6's `trilinear` and `ewa` (read as trilinear: isotropic filtering
//! over the footprint's longest axis, see docs/plugins.md) over the first hit's pixel footprint.

use super::mipmap::{Level, MipMap};
use super::{load_raw_image, UvFootprint, UvTransform, WrapMode};
use crate::color::{luminance, srgb_to_linear, Rgb};
use crate::desc::ObjectDesc;
use crate::error::{SceneError, SceneResult};
use glam::{Vec2, Vec3};

/// How a bitmap is filtered (`filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BitmapFilter {
    /// The texel containing the lookup (`nearest`).
    Nearest,
    /// Bilinear interpolation of the full-resolution image (`bilinear`, Mitsuba 3's default).
    Bilinear,
    /// Trilinear MIP-map filtering over the pixel footprint (`trilinear`).
    Trilinear,
    /// Mitsuba 0.6's elliptically weighted average (`ewa`, its default), evaluated as trilinear.
    Ewa,
}

impl BitmapFilter {
    /// Parses a `filter_type` value (case-insensitive, as Mitsuba 0.6).
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name.to_ascii_lowercase().as_str() {
            "nearest" => BitmapFilter::Nearest,
            "bilinear" => BitmapFilter::Bilinear,
            "trilinear" => BitmapFilter::Trilinear,
            "ewa" => BitmapFilter::Ewa,
            _ => return None,
        })
    }

    fn mipmapped(self) -> bool {
        matches!(self, BitmapFilter::Trilinear | BitmapFilter::Ewa)
    }
}

/// An RGB image sampled at uv coordinates.
#[derive(Clone, Debug)]
pub struct Bitmap {
    /// The image (one level unless the filter is MIP-mapped).
    pyramid: MipMap,
    filter: BitmapFilter,
    /// Wrap modes along u and v.
    wrap: [WrapMode; 2],
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
        filter: BitmapFilter,
        wrap: [WrapMode; 2],
        to_uv: UvTransform,
    ) -> Option<Self> {
        if width == 0 || height == 0 || texels.len() != width as usize * height as usize {
            return None;
        }
        let max = texels.iter().map(|t| t.max_element()).fold(0.0, f32::max);
        let mean = texels.iter().fold(Vec3::ZERO, |a, t| a + *t) / texels.len() as f32;
        let finest = Level {
            width,
            height,
            texels,
        };
        let pyramid = if filter.mipmapped() {
            MipMap::new(finest)
        } else {
            MipMap::single(finest)
        };
        Some(Bitmap {
            pyramid,
            filter,
            wrap,
            to_uv,
            max,
            mean,
        })
    }

    /// Loads a `bitmap` texture element. Parameters (Mitsuba 3 and 0.6 names): `filename` (PNG, JPEG,
    /// EXR or HDR), `raw` (skip sRGB decoding of integer images), `gamma` (0.6: 0 = automatic, -1 =
    /// sRGB, else the exponent of a power law), `channel` (0.6: `r`, `g`, `b` or `a` makes a grey
    /// texture of that channel), `filter_type` (nearest | bilinear | trilinear | ewa), `wrap_mode`,
    /// `wrap_mode_u`, `wrap_mode_v` (repeat | mirror | clamp | zero | one), the uv transform, and
    /// `max_anisotropy`, `cache`, `accel` and `format`, which are accepted and change nothing here.
    pub fn from_desc(o: &ObjectDesc) -> SceneResult<Self> {
        Self::from_desc_raw(o, o.bool_or("raw", false)?)
    }

    /// As [`Bitmap::from_desc`] with `raw` given (the normal map always reads its image raw).
    pub fn from_desc_raw(o: &ObjectDesc, raw: bool) -> SceneResult<Self> {
        let (path, loc) = o
            .resolve_path("filename")?
            .ok_or_else(|| o.error(format!("'{}' needs a 'filename'", o.plugin)))?;
        let filter = match o.prop("filter_type") {
            None => BitmapFilter::Bilinear,
            Some(p) => {
                let name = o.string_or("filter_type", "")?;
                BitmapFilter::parse(&name).ok_or_else(|| {
                    SceneError::at(
                        &p.loc,
                        format!(
                            "invalid filter_type '{name}' (nearest, bilinear, trilinear or ewa)"
                        ),
                    )
                })?
            }
        };
        let wrap_all = o.string_or("wrap_mode", "repeat")?;
        let mut wrap = [WrapMode::Repeat; 2];
        for (slot, name) in wrap.iter_mut().zip(["wrap_mode_u", "wrap_mode_v"]) {
            let mode = o.string_or(name, &wrap_all)?;
            *slot = WrapMode::parse(&mode).ok_or_else(|| {
                let at = o
                    .prop(name)
                    .or(o.prop("wrap_mode"))
                    .map_or(&o.loc, |p| &p.loc);
                SceneError::at(
                    at,
                    format!("invalid wrap mode '{mode}' (repeat, mirror, clamp, zero or one)"),
                )
            })?;
        }
        let gamma = o.float_or("gamma", 0.0)?;
        if !gamma.is_finite() || (gamma != -1.0 && gamma < 0.0) {
            let p = o.prop("gamma").expect("a non-default gamma was given");
            return Err(SceneError::at(
                &p.loc,
                format!("gamma must be -1 (sRGB), 0 (automatic) or positive, got {gamma}"),
            ));
        }
        let channel = match o.string_opt("channel")? {
            None => None,
            Some(c) => Some(match c.to_ascii_lowercase().as_str() {
                "r" => 0,
                "g" => 1,
                "b" => 2,
                "a" => 3,
                _ => {
                    let p = o.prop("channel").expect("channel was given");
                    return Err(SceneError::at(
                        &p.loc,
                        format!("invalid channel '{c}' (r, g, b or a)"),
                    ));
                }
            }),
        };
        let max_anisotropy = o.float_or("max_anisotropy", 20.0)?;
        if !(max_anisotropy > 0.0) {
            return Err(o.error(format!(
                "max_anisotropy must be positive, got {max_anisotropy}"
            )));
        }
        o.bool_or("cache", false)?;
        o.bool_or("accel", true)?;
        o.string_or("format", "")?;

        let img = load_raw_image(&path).map_err(|e| SceneError::at(&loc, e))?;
        // The transfer function: an explicit gamma, else sRGB for integer images unless raw.
        let decode = |v: f32| -> f32 {
            if gamma == -1.0 {
                srgb_to_linear(v)
            } else if gamma > 0.0 {
                v.max(0.0).powf(gamma as f32)
            } else if img.float || raw {
                v
            } else {
                srgb_to_linear(v)
            }
        };
        let texels: Vec<Rgb> = img
            .rgba
            .iter()
            .map(|p| match channel {
                // Alpha is never gamma-encoded.
                Some(3) => Rgb::splat(p[3]),
                Some(c) => Rgb::splat(decode(p[c])),
                None => Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])),
            })
            .collect();
        let w = img.width;
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
        Bitmap::new(
            w,
            img.height,
            texels,
            filter,
            wrap,
            UvTransform::from_desc(o)?,
        )
        .ok_or_else(|| SceneError::at(&loc, format!("image '{}' is empty", path.display())))
    }

    /// The filter.
    pub fn filter(&self) -> BitmapFilter {
        self.filter
    }

    /// True if lookups filter over a MIP map (`trilinear`, `ewa`).
    pub fn is_mipmapped(&self) -> bool {
        self.filter.mipmapped()
    }

    /// The MIP pyramid (a single level unless MIP-mapped).
    pub fn pyramid(&self) -> &MipMap {
        &self.pyramid
    }

    /// The largest channel value.
    pub fn max_value(&self) -> f32 {
        self.max
    }

    /// The mean texel.
    pub fn mean(&self) -> Rgb {
        self.mean
    }

    /// The value at `uv` from the full-resolution image (no footprint: later bounces, shadow rays).
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let uv = self.to_uv.apply(uv);
        if !uv.is_finite() {
            return Rgb::ZERO;
        }
        let finest = self.pyramid.finest();
        match self.filter {
            BitmapFilter::Nearest => finest.nearest(uv, self.wrap),
            _ => finest.bilinear(uv, self.wrap),
        }
    }

    /// The gradient (∂/∂u, ∂/∂v) of the luminance of the full-resolution image's bilinear
    /// interpolation at `uv`, through the uv transform (Mitsuba 3's `eval_1_grad`: zero for `nearest`,
    /// whose lookups are piecewise constant).
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        if self.filter == BitmapFilter::Nearest {
            return Vec2::ZERO;
        }
        let t = self.to_uv.apply(uv);
        if !t.is_finite() {
            return Vec2::ZERO;
        }
        let [du, dv] = self.pyramid.finest().bilinear_grad(t, self.wrap);
        let (gu, gv) = (luminance(du), luminance(dv));
        // Chain rule through the affine map u' = m0·u + m1·v + m2, v' = m3·u + m4·v + m5.
        let m = &self.to_uv.m;
        Vec2::new(gu * m[0] + gv * m[3], gu * m[1] + gv * m[4])
    }

    /// The value at `uv` filtered over the footprint `fp` (uv units before the uv transform).
    pub fn eval_filtered(&self, uv: Vec2, fp: &UvFootprint) -> Rgb {
        if !self.filter.mipmapped() {
            return self.eval(uv);
        }
        let uv = self.to_uv.apply(uv);
        if !uv.is_finite() {
            return Rgb::ZERO;
        }
        let fp = self.to_uv.apply_footprint(fp);
        self.pyramid.trilinear(uv, &fp, self.wrap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bitmap(filter: BitmapFilter, wrap: WrapMode) -> Bitmap {
        // 2×1: black on the left, white on the right.
        Bitmap::new(
            2,
            1,
            vec![Rgb::ZERO, Rgb::ONE],
            filter,
            [wrap; 2],
            UvTransform::IDENTITY,
        )
        .unwrap()
    }

    #[test]
    fn bilinear_lookups_interpolate_between_texel_centres() {
        let b = bitmap(BitmapFilter::Bilinear, WrapMode::Clamp);
        assert_eq!(b.eval(Vec2::new(0.25, 0.5)), Rgb::ZERO);
        assert_eq!(b.eval(Vec2::new(0.75, 0.5)), Rgb::ONE);
        assert!((b.eval(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        // Far outside, clamp still reads the edge texels.
        assert_eq!(b.eval(Vec2::new(-3.6, 0.5)), Rgb::ZERO);
        assert_eq!(b.eval(Vec2::new(7.3, 0.5)), Rgb::ONE);
        // Repeat wraps the right edge back to the left texel.
        let r = bitmap(BitmapFilter::Bilinear, WrapMode::Repeat);
        assert!((r.eval(Vec2::new(1.0, 0.5)).x - 0.5).abs() < 1e-6);
        assert!((r.eval(Vec2::new(-0.25, 0.5)).x - 1.0).abs() < 1e-6);
        let n = bitmap(BitmapFilter::Nearest, WrapMode::Repeat);
        assert_eq!(n.eval(Vec2::new(0.49, 0.0)), Rgb::ZERO);
        assert_eq!(n.eval(Vec2::new(0.51, 0.0)), Rgb::ONE);
        assert!(n.eval(Vec2::new(f32::NAN, 0.0)).is_finite());
    }

    #[test]
    fn zero_and_one_wrap_modes_fade_to_constants_outside() {
        let z = bitmap(BitmapFilter::Bilinear, WrapMode::Zero);
        assert_eq!(z.eval(Vec2::new(1.5, 0.5)), Rgb::ZERO);
        // Half-way between the right texel's centre and the edge's outside neighbour.
        assert!((z.eval(Vec2::new(1.0, 0.5)).x - 0.5).abs() < 1e-6);
        let o = bitmap(BitmapFilter::Nearest, WrapMode::One);
        assert_eq!(o.eval(Vec2::new(-0.2, 0.5)), Rgb::ONE);
        assert_eq!(o.eval(Vec2::new(0.2, 0.5)), Rgb::ZERO);
        assert_eq!(WrapMode::parse("Black"), Some(WrapMode::Zero));
        assert_eq!(WrapMode::parse("white"), Some(WrapMode::One));
        assert_eq!(WrapMode::parse("tile"), None);
    }

    #[test]
    fn trilinear_blurs_only_with_a_footprint() {
        let b = bitmap(BitmapFilter::Trilinear, WrapMode::Repeat);
        let uv = Vec2::new(0.25, 0.5);
        assert_eq!(b.eval(uv), Rgb::ZERO);
        assert_eq!(b.eval_filtered(uv, &UvFootprint::default()), Rgb::ZERO);
        let wide = UvFootprint {
            duv_dx: Vec2::new(0.5, 0.0),
            duv_dy: Vec2::new(0.0, 0.5),
        };
        assert!((b.eval_filtered(uv, &wide).x - 0.5).abs() < 1e-6);
        // A bilinear bitmap ignores the footprint.
        let bl = bitmap(BitmapFilter::Bilinear, WrapMode::Repeat);
        assert_eq!(bl.eval_filtered(uv, &wide), Rgb::ZERO);
        assert_eq!(BitmapFilter::parse("EWA"), Some(BitmapFilter::Ewa));
    }
}
