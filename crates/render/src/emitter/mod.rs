//! Light sources (Mitsuba's emitter plugins). Closed set on the hot path.

mod envmap;
mod spot;
pub mod sun_position;

pub use envmap::EnvMap;
pub use spot::SpotLight;

use crate::color::Rgb;
use crate::frame::Frame;
use crate::geometry::ShapeGeometry;
use crate::warp::{square_to_uniform_sphere, UNIFORM_SPHERE_PDF};
use glam::{Vec2, Vec3};

/// A light source.
#[derive(Clone, Debug)]
pub enum Emitter {
    /// `area`: uniform radiance leaving the front side of a shape.
    Area {
        /// The shape it is attached to.
        shape: u32,
        /// Emitted radiance.
        radiance: Rgb,
    },
    /// `point`: isotropic radiant intensity.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity [W/sr].
        intensity: Rgb,
    },
    /// `spot`: a masked point light.
    Spot(SpotLight),
    /// `constant`: uniform radiance from every direction at infinity.
    Constant {
        /// Radiance.
        radiance: Rgb,
    },
    /// `envmap`: an importance-sampled equirectangular image at infinity.
    Envmap(Box<EnvMap>),
    /// `directional`: a delta direction at infinity.
    Directional {
        /// Direction the light travels in (unit).
        direction: Vec3,
        /// Irradiance on a surface perpendicular to it.
        irradiance: Rgb,
    },
}

/// A sampled light direction from a reference point, for next-event estimation.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the light point (infinite for lights at infinity).
    pub dist: f32,
    /// Emitted radiance towards the reference point divided by the sampling density (for delta lights: the
    /// incident radiance-equivalent I/r² or E).
    pub weight: Rgb,
    /// Solid-angle density (not including the emitter selection probability); 0 for delta lights.
    pub pdf: f32,
    /// Delta position or direction (cannot be hit by BSDF sampling).
    pub delta: bool,
    /// Surface normal at the light point (zero for lights without a surface).
    pub n: Vec3,
}

impl Emitter {
    /// True for lights at infinity that escaping rays see (constant; envmap later).
    pub fn is_environment(&self) -> bool {
        matches!(self, Emitter::Constant { .. } | Emitter::Envmap(_))
    }

    /// True for delta position/direction lights.
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Emitter::Point { .. } | Emitter::Spot(_) | Emitter::Directional { .. }
        )
    }

    /// Samples a direction from reference point `x` towards this light. `shapes` gives area lights their
    /// geometry. `None` if the light cannot contribute.
    /// `u1` chooses a triangle of a mesh light, `u` samples the position or direction.
    pub fn sample_direction(
        &self,
        shapes: &[ShapeGeometry],
        x: Vec3,
        u1: f32,
        u: Vec2,
    ) -> Option<EmitterSample> {
        match self {
            Emitter::Area { shape, radiance } => {
                let g = &shapes[*shape as usize];
                let (wi, dist, pdf, n) = match g {
                    ShapeGeometry::Sphere(s) => {
                        let (d, t, pdf) = s.sample_direction(x, u)?;
                        let p = s.project(x + d * t);
                        (d, t, pdf, s.normal(p))
                    }
                    _ => {
                        let ps = g.sample_position(u1, u);
                        let v = ps.p - x;
                        let d2 = v.length_squared();
                        if !(d2 > 0.0) {
                            return None;
                        }
                        let dist = d2.sqrt();
                        let wi = v / dist;
                        let cos = -ps.n.dot(wi);
                        if cos <= 0.0 {
                            return None;
                        }
                        (wi, dist, ps.pdf_area * d2 / cos, ps.n)
                    }
                };
                // Front side only: the light point must face x.
                if n.dot(wi) >= 0.0 || !(pdf > 0.0) || !pdf.is_finite() {
                    return None;
                }
                Some(EmitterSample {
                    wi,
                    dist,
                    weight: *radiance / pdf,
                    pdf,
                    delta: false,
                    n,
                })
            }
            Emitter::Point {
                position,
                intensity,
            } => {
                let v = *position - x;
                let d2 = v.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let dist = d2.sqrt();
                Some(EmitterSample {
                    wi: v / dist,
                    dist,
                    weight: *intensity / d2,
                    pdf: 0.0,
                    delta: true,
                    n: Vec3::ZERO,
                })
            }
            Emitter::Spot(s) => s.sample_direction(x),
            Emitter::Constant { radiance } => {
                let wi = square_to_uniform_sphere(u);
                Some(EmitterSample {
                    wi,
                    dist: f32::INFINITY,
                    weight: *radiance / UNIFORM_SPHERE_PDF,
                    pdf: UNIFORM_SPHERE_PDF,
                    delta: false,
                    n: Vec3::ZERO,
                })
            }
            Emitter::Envmap(e) => {
                let (wi, pdf, radiance) = e.sample(u)?;
                Some(EmitterSample {
                    wi,
                    dist: f32::INFINITY,
                    weight: radiance / pdf,
                    pdf,
                    delta: false,
                    n: Vec3::ZERO,
                })
            }
            Emitter::Directional {
                direction,
                irradiance,
            } => Some(EmitterSample {
                wi: -*direction,
                dist: f32::INFINITY,
                weight: *irradiance,
                pdf: 0.0,
                delta: true,
                n: Vec3::ZERO,
            }),
        }
    }

    /// Solid-angle density with which [`Emitter::sample_direction`] from `x` produces the direction towards
    /// the light point `p` with normal `n` (for area lights), or direction `d` (for environments).
    pub fn pdf_direction(&self, shapes: &[ShapeGeometry], x: Vec3, p: Vec3, n: Vec3) -> f32 {
        match self {
            Emitter::Area { shape, .. } => {
                let g = &shapes[*shape as usize];
                match g {
                    ShapeGeometry::Sphere(s) => s.pdf_direction(x, p, n),
                    _ => {
                        let v = p - x;
                        let d2 = v.length_squared();
                        let cos = n.dot(v).abs() / d2.sqrt();
                        if !(cos > 0.0) {
                            return 0.0;
                        }
                        d2 / (cos * g.area())
                    }
                }
            }
            Emitter::Constant { .. } => UNIFORM_SPHERE_PDF,
            Emitter::Envmap(e) => e.pdf(p),
            _ => 0.0,
        }
    }

    /// Radiance an environment light sends along direction `-d` towards a ray travelling along `d`.
    pub fn eval_environment(&self, _d: Vec3) -> Rgb {
        match self {
            Emitter::Constant { radiance } => *radiance,
            Emitter::Envmap(e) => e.eval(_d),
            _ => Rgb::ZERO,
        }
    }

    /// Radiance leaving an area light's surface towards `wi_local` (the shading-frame direction back along
    /// the incoming ray): front side only.
    #[inline]
    pub fn eval_area(&self, wi_local_z: f32) -> Rgb {
        match self {
            Emitter::Area { radiance, .. } if wi_local_z > 0.0 => *radiance,
            _ => Rgb::ZERO,
        }
    }

    /// Total emitted power estimate (used for reporting).
    pub fn describe(&self) -> String {
        match self {
            Emitter::Area { shape, radiance } => {
                format!("area(shape {shape}, radiance {radiance})")
            }
            Emitter::Point {
                position,
                intensity,
            } => format!("point(at {position}, intensity {intensity})"),
            Emitter::Spot(s) => format!("spot(at {}, intensity {})", s.position(), s.intensity),
            Emitter::Constant { radiance } => format!("constant(radiance {radiance})"),
            Emitter::Envmap(_) => "envmap".to_string(),
            Emitter::Directional {
                direction,
                irradiance,
            } => {
                format!("directional(direction {direction}, irradiance {irradiance})")
            }
        }
    }
}

/// Builds a frame whose +Z is `dir` (used by lights defined along local +Z).
pub fn frame_along(dir: Vec3) -> Frame {
    Frame::from_normal(dir.normalize())
}
