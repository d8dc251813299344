//! The MIP map of a bitmap texture: the image at successively halved resolutions (area-weighted box
//! downsampling, any size), looked up with bilinear interpolation within a level and linear blending
//! between the two levels around the footprint's width (Mitsuba 0.6's `trilinear` filter).

use super::{UvFootprint, WrapMode};
use crate::color::Rgb;
use glam::Vec2;

/// One level of the pyramid: linear RGB, row-major from the top row.
#[derive(Clone, Debug)]
pub struct Level {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, `width × height`.
    pub texels: Vec<Rgb>,
}

impl Level {
    /// The texel at integer coordinates, with the wrap modes applied per axis.
    #[inline]
    pub fn texel(&self, x: i64, y: i64, wrap: [WrapMode; 2]) -> Rgb {
        let (w, h) = (self.width as i64, self.height as i64);
        let (Some(fx), Some(fy)) = (wrap[0].fold(x, w), wrap[1].fold(y, h)) else {
            // Outside under `zero`/`one`: the constant of whichever axis left the image.
            let outside = if wrap[0].fold(x, w).is_none() {
                wrap[0]
            } else {
                wrap[1]
            };
            return outside.constant();
        };
        self.texels[fy * self.width as usize + fx]
    }

    /// Bilinear interpolation between texel centres at `uv` (texel (0, 0) covers [0, 1/w) × [0, 1/h)).
    #[inline]
    pub fn bilinear(&self, uv: Vec2, wrap: [WrapMode; 2]) -> Rgb {
        let x = wrap[0].reduce(uv.x as f64 * self.width as f64, self.width);
        let y = wrap[1].reduce(uv.y as f64 * self.height as f64, self.height);
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0, wrap) * (1.0 - tx) + self.texel(x0 + 1, y0, wrap) * tx;
        let bottom =
            self.texel(x0, y0 + 1, wrap) * (1.0 - tx) + self.texel(x0 + 1, y0 + 1, wrap) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// The derivatives ∂/∂u and ∂/∂v of [`Level::bilinear`] at `uv` (constant within a cell between
    /// four texel centres), as Mitsuba 3's `eval_1_grad`.
    #[inline]
    pub fn bilinear_grad(&self, uv: Vec2, wrap: [WrapMode; 2]) -> [Rgb; 2] {
        let x = wrap[0].reduce(uv.x as f64 * self.width as f64, self.width);
        let y = wrap[1].reduce(uv.y as f64 * self.height as f64, self.height);
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let f00 = self.texel(x0, y0, wrap);
        let f10 = self.texel(x0 + 1, y0, wrap);
        let f01 = self.texel(x0, y0 + 1, wrap);
        let f11 = self.texel(x0 + 1, y0 + 1, wrap);
        let d_x = (f10 - f00) * (1.0 - ty) + (f11 - f01) * ty;
        let d_y = (f01 - f00) * (1.0 - tx) + (f11 - f10) * tx;
        [d_x * self.width as f32, d_y * self.height as f32]
    }

    /// The texel containing `uv` (no interpolation).
    #[inline]
    pub fn nearest(&self, uv: Vec2, wrap: [WrapMode; 2]) -> Rgb {
        let x = wrap[0].reduce(uv.x as f64 * self.width as f64, self.width);
        let y = wrap[1].reduce(uv.y as f64 * self.height as f64, self.height);
        self.texel(x.floor() as i64, y.floor() as i64, wrap)
    }

    /// The next coarser level: half the size (rounded down, at least 1), each texel the area-weighted
    /// mean of the texels it covers.
    fn downsample(&self) -> Level {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let wx = box_weights(self.width, w);
        let wy = box_weights(self.height, h);
        let mut texels = Vec::with_capacity(w as usize * h as usize);
        for row in &wy {
            for col in &wx {
                let mut sum = Rgb::ZERO;
                for &(sy, ky) in row {
                    for &(sx, kx) in col {
                        sum += self.texels[sy * self.width as usize + sx] * (kx * ky);
                    }
                }
                texels.push(sum);
            }
        }
        Level {
            width: w,
            height: h,
            texels,
        }
    }
}

/// For each of `to` output texels, the source texels of a row of `from` it overlaps and their weights
/// (overlap length / output texel length, summing to 1).
fn box_weights(from: u32, to: u32) -> Vec<Vec<(usize, f32)>> {
    let ratio = from as f64 / to as f64;
    (0..to)
        .map(|i| {
            let (a, b) = (i as f64 * ratio, (i + 1) as f64 * ratio);
            let mut out = Vec::with_capacity(3);
            let mut s = a.floor() as usize;
            while (s as f64) < b && s < from as usize {
                let overlap = (b.min(s as f64 + 1.0) - a.max(s as f64)).max(0.0);
                if overlap > 0.0 {
                    out.push((s, (overlap / ratio) as f32));
                }
                s += 1;
            }
            out
        })
        .collect()
}

/// A MIP pyramid, finest level first, down to 1 × 1.
#[derive(Clone, Debug)]
pub struct MipMap {
    levels: Vec<Level>,
}

impl MipMap {
    /// Builds the pyramid over `finest`.
    pub fn new(finest: Level) -> Self {
        let mut levels = vec![finest];
        loop {
            let last = levels.last().expect("at least one level");
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = last.downsample();
            levels.push(next);
        }
        MipMap { levels }
    }

    /// A "pyramid" of just the given image (for filters that never leave the finest level).
    pub fn single(finest: Level) -> Self {
        MipMap {
            levels: vec![finest],
        }
    }

    /// The levels, finest first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// The finest level.
    pub fn finest(&self) -> &Level {
        &self.levels[0]
    }

    /// The continuous level whose texels are as wide as the footprint: Mitsuba 0.6's isotropic rule,
    /// width = 2·max(|∂u/∂x|, |∂v/∂x|, |∂u/∂y|, |∂v/∂y|) in uv units, level = log2(width · resolution)
    /// with the resolution of the finest level's larger side (0 = finest; clamped to the pyramid).
    pub fn level_of(&self, fp: &UvFootprint) -> f32 {
        let d = fp.duv_dx.abs().max(fp.duv_dy.abs());
        let width = 2.0 * d.x.max(d.y);
        let res = self.levels[0].width.max(self.levels[0].height) as f32;
        let level = (width * res).max(1e-8).log2();
        if level.is_nan() {
            return 0.0;
        }
        level.clamp(0.0, (self.levels.len() - 1) as f32)
    }

    /// Trilinear lookup at `uv` over the footprint `fp` (a zero footprint reads the finest level
    /// bilinearly, as Mitsuba 0.6 does for rays without differentials).
    pub fn trilinear(&self, uv: Vec2, fp: &UvFootprint, wrap: [WrapMode; 2]) -> Rgb {
        let level = self.level_of(fp);
        let lower = level.floor() as usize;
        let t = level - lower as f32;
        let a = self.levels[lower].bilinear(uv, wrap);
        if t <= 0.0 || lower + 1 >= self.levels.len() {
            return a;
        }
        a * (1.0 - t) + self.levels[lower + 1].bilinear(uv, wrap) * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(n: u32) -> Level {
        let texels = (0..n * n)
            .map(|i| {
                if (i % n + i / n).is_multiple_of(2) {
                    Rgb::ONE
                } else {
                    Rgb::ZERO
                }
            })
            .collect();
        Level {
            width: n,
            height: n,
            texels,
        }
    }

    #[test]
    fn levels_halve_down_to_one_texel_and_keep_the_mean() {
        for (w, h) in [(8u32, 8u32), (5, 3), (1, 7), (6, 1)] {
            let texels: Vec<Rgb> = (0..w * h).map(|i| Rgb::splat(i as f32)).collect();
            let mean = texels.iter().sum::<Rgb>() / (w * h) as f32;
            let m = MipMap::new(Level {
                width: w,
                height: h,
                texels,
            });
            let last = m.levels().last().unwrap();
            assert_eq!((last.width, last.height), (1, 1));
            for l in m.levels() {
                let lm = l.texels.iter().sum::<Rgb>() / l.texels.len() as f32;
                assert!(
                    (lm - mean).abs().max_element() < 1e-3 * mean.x.max(1.0),
                    "{w}x{h}"
                );
            }
        }
    }

    #[test]
    fn footprint_selects_the_level() {
        let m = MipMap::new(checker(64));
        let fp = |d: f32| UvFootprint {
            duv_dx: Vec2::new(d, 0.0),
            duv_dy: Vec2::new(0.0, d),
        };
        assert_eq!(m.level_of(&UvFootprint::default()), 0.0);
        // A footprint two texels wide reads level 1 (texels of the finest level's size 2).
        assert!((m.level_of(&fp(1.0 / 64.0)) - 1.0).abs() < 1e-5);
        assert_eq!(m.level_of(&fp(10.0)), 6.0);
        // A wide footprint over a checkerboard gives its mean, a tiny one a texel.
        let wrap = [WrapMode::Repeat; 2];
        let uv = Vec2::new(0.3, 0.6);
        assert!(
            (m.trilinear(uv, &fp(1.0), wrap) - Rgb::splat(0.5))
                .abs()
                .max_element()
                < 1e-6
        );
        let sharp = m.trilinear(Vec2::new(0.5 / 64.0, 0.5 / 64.0), &fp(1e-6), wrap);
        assert_eq!(sharp, Rgb::ONE);
        assert!(m.trilinear(uv, &fp(f32::NAN), wrap).is_finite());
    }
}
