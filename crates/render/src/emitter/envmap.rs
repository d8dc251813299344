//! Environment maps (Mitsuba `envmap`): an equirectangular image at infinity, importance-sampled by
//! luminance × sin θ. Directions map to the image as in Mitsuba (local Y up): u = atan2(x, −z)/2π,
//! v = acos(y)/π, so row 0 is the zenith. Lookups take the nearest texel, so the sampling density and the
//! radiance are both piecewise constant per texel and agree exactly (Mitsuba filters bilinearly).

use crate::color::{luminance, Rgb};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// An importance-sampled equirectangular environment.
#[derive(Clone, Debug)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Radiance (already times `scale`), row-major from the top (zenith) row.
    texels: Vec<Rgb>,
    to_world: Mat3,
    to_local: Mat3,
    /// Cumulative row weights (normalised, `height` entries).
    row_cdf: Vec<f32>,
    /// Cumulative weights within each row (normalised per row, `height × width` entries).
    col_cdf: Vec<f32>,
    /// Probability of each texel (sums to 1).
    texel_prob: Vec<f32>,
}

impl EnvMap {
    /// An environment from linear radiance texels and the rotation part of `to_world`. `None` if the
    /// map is empty or has no positive texel (nothing to sample).
    pub fn new(width: usize, height: usize, texels: Vec<Rgb>, to_world: Mat3) -> Option<Self> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return None;
        }
        let mut weights = vec![0f64; width * height];
        for y in 0..height {
            let sin_theta = ((y as f64 + 0.5) / height as f64 * std::f64::consts::PI).sin();
            for x in 0..width {
                let l = luminance(texels[y * width + x]).max(0.0) as f64;
                weights[y * width + x] = if l.is_finite() { l * sin_theta } else { 0.0 };
            }
        }
        let total: f64 = weights.iter().sum();
        if !(total > 0.0) {
            return None;
        }
        let mut row_cdf = Vec::with_capacity(height);
        let mut col_cdf = Vec::with_capacity(width * height);
        let mut acc = 0.0;
        for y in 0..height {
            let row = &weights[y * width..(y + 1) * width];
            let row_sum: f64 = row.iter().sum();
            acc += row_sum;
            row_cdf.push((acc / total) as f32);
            let mut a = 0.0;
            for w in row {
                a += w;
                col_cdf.push(if row_sum > 0.0 {
                    (a / row_sum) as f32
                } else {
                    0.0
                });
            }
        }
        let texel_prob = weights.iter().map(|w| (w / total) as f32).collect();
        Some(EnvMap {
            width,
            height,
            texels,
            to_world,
            to_local: to_world.inverse(),
            row_cdf,
            col_cdf,
            texel_prob,
        })
    }

    fn texel_of(&self, d_world: Vec3) -> Option<(usize, usize, f32)> {
        let d = (self.to_local * d_world).normalize_or_zero();
        if d == Vec3::ZERO {
            return None;
        }
        let mut u = d.x.atan2(-d.z) / (2.0 * PI);
        u -= u.floor();
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        let x = ((u * self.width as f32) as usize).min(self.width - 1);
        let y = ((v * self.height as f32) as usize).min(self.height - 1);
        let sin_theta = (1.0 - d.y * d.y).max(0.0).sqrt();
        Some((x, y, sin_theta))
    }

    /// Radiance arriving from world direction `d` (towards the environment).
    pub fn eval(&self, d: Vec3) -> Rgb {
        match self.texel_of(d) {
            Some((x, y, _)) => self.texels[y * self.width + x],
            None => Rgb::ZERO,
        }
    }

    /// Solid-angle density of [`EnvMap::sample`] producing world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let Some((x, y, sin_theta)) = self.texel_of(d) else {
            return 0.0;
        };
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        // Texel probability over its area in the unit square, then dω = 2π² sin θ du dv.
        let p_uv = self.texel_prob[y * self.width + x] * (self.width * self.height) as f32;
        p_uv / (2.0 * PI * PI * sin_theta)
    }

    /// Samples a world direction towards the environment: (direction, solid-angle pdf, radiance).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32, Rgb)> {
        let y = self
            .row_cdf
            .partition_point(|&c| c <= u.x)
            .min(self.height - 1);
        let row_lo = if y == 0 { 0.0 } else { self.row_cdf[y - 1] };
        let row_p = self.row_cdf[y] - row_lo;
        if !(row_p > 0.0) {
            return None;
        }
        let fy = ((u.x - row_lo) / row_p).clamp(0.0, 1.0 - f32::EPSILON);
        let cols = &self.col_cdf[y * self.width..(y + 1) * self.width];
        let x = cols.partition_point(|&c| c <= u.y).min(self.width - 1);
        let col_lo = if x == 0 { 0.0 } else { cols[x - 1] };
        let col_p = cols[x] - col_lo;
        if !(col_p > 0.0) {
            return None;
        }
        let fx = ((u.y - col_lo) / col_p).clamp(0.0, 1.0 - f32::EPSILON);
        let uu = (x as f32 + fx) / self.width as f32;
        let vv = (y as f32 + fy) / self.height as f32;
        let (phi, theta) = (uu * 2.0 * PI, vv * PI);
        let local = Vec3::new(
            phi.sin() * theta.sin(),
            theta.cos(),
            -phi.cos() * theta.sin(),
        );
        let d = (self.to_world * local).normalize();
        let pdf = self.pdf(d);
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        Some((d, pdf, self.eval(d)))
    }
}
