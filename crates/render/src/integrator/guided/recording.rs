//! Recording a guided path's segments as training data: each segment's endpoint, its glossy or glass
//! status and its contribution are known only later along the path, so segments wait in a pending list
//! until the path ends.

use crate::color::Rgb;
use focal_guiding::TrainingSegment;
use glam::Vec3;

use super::direction::Step;
use super::STRAIGHT_THROUGH_COS;

/// A recorded segment whose contribution is not known until the path ends.
#[derive(Clone, Copy)]
pub(super) struct PendingSegment {
    segment: TrainingSegment,
    /// The path's estimate just before the segment was sampled: everything added later flows through it.
    result_before: Rgb,
    /// The endpoint is glossy glass and the path has not yet left the glass: whether the straight line
    /// through it points where the light came from is not known yet.
    in_glass: bool,
    /// The path refracted (η ≠ 1) since this segment's endpoint.
    refracted: bool,
}

/// The pending segments of one camera sample's path (and of its split-off copies, which record none).
pub(super) struct SegmentRecorder {
    pending: Vec<PendingSegment>,
    /// The first pending segment that may still be inside a run of glass vertices.
    glass_from: Option<usize>,
    record: bool,
}

impl SegmentRecorder {
    /// A recorder over the (reused) buffer `pending`; with `record` false it records nothing.
    pub(super) fn new(mut pending: Vec<PendingSegment>, record: bool) -> Self {
        pending.clear();
        SegmentRecorder {
            pending,
            glass_from: None,
            record,
        }
    }

    /// Whether segments are recorded.
    #[inline]
    pub(super) fn records(&self) -> bool {
        self.record
    }

    /// Books emission MIS-weighted against NEE (pdf `nee_pdf`, 0 where NEE cannot compete) on the segment
    /// that reached it, if it is the endpoint of the last pending segment (whose distance is still open).
    #[inline]
    pub(super) fn emission(&mut self, emitted: Rgb, nee_pdf: f32) {
        if let Some(last) = self.pending.last_mut() {
            if last.segment.distance < 0.0 && nee_pdf > 0.0 {
                last.segment.emitted += emitted.element_sum() / 3.0;
                last.segment.emitter_pdf = nee_pdf;
            }
        }
    }

    /// The path's ray in direction `d` left the scene: a segment still inside glass is settled, and with
    /// `train_escaped` the last segment becomes a half-line.
    pub(super) fn escaped(&mut self, d: Vec3, train_escaped: bool) {
        if let Some(from) = self.glass_from.take() {
            leave_glass(&mut self.pending, from, d);
        }
        if train_escaped {
            if let Some(last) = self.pending.last_mut() {
                if last.segment.distance < 0.0 {
                    last.segment.distance = f32::INFINITY;
                }
            }
        }
    }

    /// The path's ray in direction `d` reached a scattering vertex at `distance` (`glossy`, and glossy
    /// glass if `glass`): the last segment gets its endpoint, and a run of glass is settled when the
    /// path leaves it.
    pub(super) fn reached(&mut self, distance: f32, glossy: bool, glass: bool, d: Vec3) {
        if !glass {
            if let Some(from) = self.glass_from.take() {
                leave_glass(&mut self.pending, from, d);
            }
        }
        let open = self.pending.len();
        if let Some(last) = self.pending.last_mut() {
            if last.segment.distance < 0.0 {
                last.segment.distance = distance;
                last.segment.glossy_endpoint = glossy;
                if glass {
                    last.in_glass = true;
                    self.glass_from.get_or_insert(open - 1);
                }
            }
        }
    }

    /// The vertex scattered with relative index of refraction `eta`: segments ending in the current run
    /// of glass see a refraction.
    #[inline]
    pub(super) fn scattered(&mut self, eta: f32) {
        if let Some(from) = self.glass_from {
            if eta != 1.0 {
                self.pending[from..]
                    .iter_mut()
                    .for_each(|p| p.refracted = true);
            }
        }
    }

    /// Records the segment just sampled at `origin` (`glossy` there, guide fraction `guide_fraction`), its
    /// endpoint still open, with the path's estimate so far, if this recorder records.
    pub(super) fn sampled(
        &mut self,
        origin: Vec3,
        step: &Step,
        guide_fraction: f32,
        glossy: bool,
        result_before: Rgb,
    ) {
        if !self.record {
            return;
        }
        self.pending.push(PendingSegment {
            segment: TrainingSegment {
                origin,
                direction: step.wo_world,
                distance: -1.0,
                weight: 0.0,
                pdf: step.pdf,
                bsdf_pdf: step.bsdf_pdf,
                guide_pdf: step.guide_pdf,
                guide_fraction,
                glossy_endpoint: false,
                glossy_origin: glossy,
                refracting_endpoint: false,
                emitted: 0.0,
                emitter_pdf: 0.0,
                pixel_weight: 1.0,
            },
            result_before,
            in_glass: false,
            refracted: false,
        });
    }

    /// A split-off copy resumes: it starts outside any run of glass of its own.
    pub(super) fn resume(&mut self) {
        self.glass_from = None;
    }

    /// The path ended with estimate `result`: every segment with an endpoint and a positive, finite
    /// contribution (what was added after it was sampled) goes to `training`. Returns the buffer.
    pub(super) fn finish(
        self,
        result: Rgb,
        training: Option<&mut Vec<TrainingSegment>>,
    ) -> Vec<PendingSegment> {
        if let Some(training) = training {
            for p in &self.pending {
                // Segments whose ray escaped or was never traced carry no endpoint.
                if p.segment.distance < 0.0 {
                    continue;
                }
                let c = (result - p.result_before).element_sum() / 3.0;
                if c > 0.0 && c.is_finite() {
                    let mut seg = p.segment;
                    seg.weight = c;
                    training.push(seg);
                }
            }
        }
        self.pending
    }
}

/// Settles `refracting_endpoint` for the segments `pending[from..]` that ended on glass, now that the path
/// has left the glass in direction `d_out` (to a non-glass vertex, or out of the scene): the path bent
/// by refraction if it refracted on the way and left at more than arccos([`STRAIGHT_THROUGH_COS`]) from
/// the segment's direction. Reflection off glass keeps the line (a mirror's virtual image).
fn leave_glass(pending: &mut [PendingSegment], from: usize, d_out: Vec3) {
    for p in pending[from..].iter_mut().filter(|p| p.in_glass) {
        p.in_glass = false;
        p.segment.refracting_endpoint =
            p.refracted && p.segment.direction.dot(d_out) < STRAIGHT_THROUGH_COS;
    }
}
