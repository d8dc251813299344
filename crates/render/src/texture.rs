//! Spatially varying parameters of BSDFs. Constant values now; bitmap and procedural textures plug in here.

use crate::color::Rgb;
use glam::Vec2;

/// A colour- or scalar-valued texture evaluated at surface uv coordinates.
#[derive(Clone, Debug)]
pub enum Texture {
    /// The same value everywhere (`<rgb>`, `<spectrum>`, `<float>` properties).
    Constant(Rgb),
}

impl Texture {
    /// A constant grey value.
    pub fn constant(v: f32) -> Self {
        Texture::Constant(Rgb::splat(v))
    }

    /// The value at `uv`.
    #[inline]
    pub fn eval(&self, _uv: Vec2) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
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
        }
    }
}
