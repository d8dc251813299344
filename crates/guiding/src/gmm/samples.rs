//! The GMM guide's training-sample storage: the iteration's segments clipped to training rays in the
//! guide's unit frame, one buffer per mixture, thinned beyond a cap.

use glam::DVec3;

use super::guide::{unit, GmmGuide};
use super::rays::{clip_to_box, TrainingRay};
use crate::{GuidingField, SampleStorage, TrainingSegment};

/// Training rays of one iteration and what became of its segments.
#[derive(Clone, Debug, Default)]
pub(super) struct GmmSamples {
    /// Rays of the converging mixture.
    pub conv: Vec<TrainingRay>,
    /// Rays of the diverging mixture (the backward half-lines of glossy endpoints).
    pub div: Vec<TrainingRay>,
    /// Segments with an invalid weight, pdf or geometry.
    pub dropped: u64,
    /// Rays that missed the box or carried nothing after clipping.
    pub empty: u64,
    /// Times a buffer was thinned.
    pub thinned: u64,
}

impl GmmGuide {
    /// The (converging, diverging) training rays in `samples`, a storage of this guide's.
    pub fn stored_rays(&self, samples: &mut SampleStorage) -> (usize, usize) {
        let rays: &GmmSamples = samples.data_mut(self.updates, 0);
        (rays.conv.len(), rays.div.len())
    }

    /// An empty storage for the current model.
    pub(super) fn empty_samples(&self) -> SampleStorage {
        SampleStorage::new(self.name(), self.updates, GmmSamples::default())
    }

    /// Adds the batch to a storage of this guide's.
    pub(super) fn add_to_storage(&self, samples: &mut SampleStorage, segments: &[TrainingSegment]) {
        self.record(samples.data_mut(self.updates, segments.len()), segments);
    }

    /// The rays of a storage of this guide's and its segment count, for the update.
    pub(super) fn take_samples(&self, samples: SampleStorage) -> (GmmSamples, u64) {
        samples.into_data::<GmmSamples>(self.updates)
    }

    /// Clips the batch's segments to rays and buffers them (`docs/design/octree.md` §3.3): the segment for
    /// a non-glossy endpoint, the forward and backward half-lines for a glossy one (unless the path
    /// refracted through it and `points.extend_through_refraction` is off). Segments with a non-finite
    /// or negative weight, an invalid pdf or geometry are dropped, zero weights skipped.
    pub(super) fn record(&self, samples: &mut GmmSamples, segments: &[TrainingSegment]) {
        for s in segments {
            let c = s.weight as f64;
            let pdf = s.pdf as f64;
            if !c.is_finite() || c < 0.0 || !(pdf > 0.0 && pdf.is_finite()) {
                samples.dropped += 1;
                continue;
            }
            if c == 0.0 {
                continue;
            }
            let o = self.to_unit(s.origin);
            let Some(d) = unit(s.direction.as_dvec3()) else {
                samples.dropped += 1;
                continue;
            };
            if !o.is_finite() {
                samples.dropped += 1;
                continue;
            }
            if s.glossy_endpoint
                && (self.config.points.extend_through_refraction || !s.refracting_endpoint)
            {
                self.push_ray(samples, false, o, d, f64::INFINITY, c, pdf);
                self.push_ray(samples, true, o, -d, f64::INFINITY, c, pdf);
            } else {
                let distance = s.distance as f64 / self.scale;
                if !(distance >= 0.0) {
                    samples.dropped += 1;
                    continue;
                }
                self.push_ray(samples, false, o, d, distance, c, pdf);
            }
        }
    }

    /// Clips one ray to the box and buffers it (thinning the buffer if it overflows).
    #[allow(clippy::too_many_arguments)]
    fn push_ray(
        &self,
        samples: &mut GmmSamples,
        diverging: bool,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        c: f64,
        pdf: f64,
    ) {
        let (lo, hi) = self.unit_box();
        let Some((t0, t1)) = clip_to_box(o, d, t_max, lo, hi) else {
            samples.empty += 1;
            return;
        };
        let ray = TrainingRay {
            origin: o.as_vec3().to_array(),
            direction: d.as_vec3().to_array(),
            t0: t0 as f32,
            t1: t1 as f32,
            weight: c as f32,
            pdf: pdf as f32,
        };
        if !(ray.t1 > ray.t0 && ray.weight > 0.0 && ray.weight.is_finite()) {
            samples.empty += 1;
            return;
        }
        let buffer = if diverging {
            &mut samples.div
        } else {
            &mut samples.conv
        };
        buffer.push(ray);
        if buffer.len() > self.config.points.max_rays {
            thin(buffer);
            samples.thinned += 1;
        }
    }
}

/// Keeps every other ray with doubled weight: the buffer's expected total weight is unchanged.
fn thin(buffer: &mut Vec<TrainingRay>) {
    let mut keep = 0;
    for i in (0..buffer.len()).step_by(2) {
        let mut ray = buffer[i];
        ray.weight = (ray.weight * 2.0).min(f32::MAX);
        buffer[keep] = ray;
        keep += 1;
    }
    buffer.truncate(keep);
}
