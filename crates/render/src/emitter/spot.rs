//! Spot lights (Mitsuba `spot`): a point light masked by a cone, with Mitsuba 3's linear-in-angle falloff.

use super::EmitterSample;
use crate::color::Rgb;
use crate::frame::Frame;
use glam::Vec3;

/// A spot light pointing along its local +Z axis.
#[derive(Clone, Debug)]
pub struct SpotLight {
    frame: Frame,
    position: Vec3,
    /// Radiant intensity on the axis [W/sr].
    pub intensity: Rgb,
    cutoff: f32,
    beam_width: f32,
    cos_cutoff: f32,
    cos_beam_width: f32,
}

impl SpotLight {
    /// A spot at `position` pointing along `axis`; angles in radians (`beam_width` ≤ `cutoff`).
    pub fn new(position: Vec3, axis: Vec3, intensity: Rgb, cutoff: f32, beam_width: f32) -> Self {
        SpotLight {
            frame: Frame::from_normal(axis.normalize()),
            position,
            intensity,
            cutoff,
            beam_width,
            cos_cutoff: cutoff.cos(),
            cos_beam_width: beam_width.cos(),
        }
    }

    /// Position of the light.
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// Angular falloff for a local direction: 1 inside the beam, linear in the angle down to 0 at the cutoff.
    pub fn falloff(&self, local: Vec3) -> f32 {
        let cos_theta = local.z;
        if cos_theta >= self.cos_beam_width {
            1.0
        } else if cos_theta > self.cos_cutoff {
            let theta = cos_theta.clamp(-1.0, 1.0).acos();
            ((self.cutoff - theta) / (self.cutoff - self.beam_width)).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    pub(super) fn sample_direction(&self, x: Vec3) -> Option<EmitterSample> {
        let v = self.position - x;
        let d2 = v.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = v / dist;
        let f = self.falloff(self.frame.to_local(-wi));
        if f <= 0.0 {
            return None;
        }
        Some(EmitterSample {
            wi,
            dist,
            weight: self.intensity * (f / d2),
            pdf: 0.0,
            delta: true,
            n: Vec3::ZERO,
        })
    }
}
