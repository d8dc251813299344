//! Finding the samples behind a guided render's fireflies.
//!
//! The error of one focal render is mostly a handful of samples far brighter than their pixel's true
//! value. This re-renders every sample of a render with a fixed guide (the same random streams as
//! `render --load-guide` with the same seed and spp, so the same samples), scores each against a
//! reference pixel by its share of the image's relMSE, (L − r)² / (r² + ε) with L and r the means over
//! channels of the sample and the reference pixel, and keeps the highest-scoring ones with a record of
//! their paths ([`PathTrace`]): which vertex chose its direction how, with which densities, where Russian
//! roulette boosted the throughput, and which light the path found. Summed over all samples and divided
//! by pixels × spp², the scores estimate the image's relMSE (the reconstruction filter's spread aside),
//! so the top samples' share says how much of the error they carry.

use crate::camera::Camera;
use crate::eval::metrics::finite;
use crate::film::{FilmSpec, Image};
use crate::integrator::path_trace::PathTrace;
use crate::integrator::GuidedPathIntegrator;
use crate::render::{camera_sample, thread_pool, RenderSettings};
use crate::scene::Scene;
use glam::IVec2;
use rayon::prelude::*;

/// One sample that stood out against the reference.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Firefly {
    /// The film pixel (x, y) the sample belongs to.
    pub pixel: [u32; 2],
    /// The sample's index in that pixel.
    pub sample_index: u32,
    /// The mean over channels of the sample's radiance estimate.
    pub value: f32,
    /// The mean over channels of the reference pixel.
    pub reference: f32,
    /// (L − r)² / (r² + ε): the sample's weight in the image's relMSE.
    pub score: f64,
    /// The path.
    pub trace: PathTrace,
}

/// What [`find_fireflies`] found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FireflyReport {
    /// Samples rendered.
    pub samples: u64,
    /// Samples per pixel.
    pub spp: u32,
    /// The sum of all samples' scores.
    pub total_score: f64,
    /// `total_score` over pixels × spp²: the relMSE the scores imply.
    pub implied_rel_mse: f64,
    /// The share of all samples' scores held by `fireflies`.
    pub top_share: f64,
    /// The highest-scoring samples, highest first (ties in pixel and sample order).
    pub fireflies: Vec<Firefly>,
}

/// Renders `settings.spp` samples of every pixel of `spec`'s window with `integrator` (the same samples
/// as a pretrained guided render of these settings) and returns the `count` that score highest against
/// `reference` (the window's size) with relMSE's `epsilon`.
#[allow(clippy::too_many_arguments)]
pub fn find_fireflies(
    scene: &Scene,
    camera: &Camera,
    spec: &FilmSpec,
    integrator: &GuidedPathIntegrator,
    settings: &RenderSettings,
    reference: &Image,
    epsilon: f64,
    count: usize,
) -> Result<FireflyReport, String> {
    let (w, h) = (spec.crop_size.x, spec.crop_size.y);
    if reference.width != w || reference.height != h {
        return Err(format!(
            "the reference is {}x{}, the render {w}x{h}",
            reference.width, reference.height
        ));
    }
    let (pool, _) = thread_pool(settings.threads);
    let rows: Vec<(Vec<Firefly>, f64)> = pool.install(|| {
        (0..h)
            .into_par_iter()
            .map(|y| {
                let mut best: Vec<Firefly> = Vec::new();
                let mut total = 0.0f64;
                let mut trace = PathTrace::default();
                for x in 0..w {
                    let r = reference.rgb[(y * w + x) as usize];
                    // As relMSE reads it: a non-finite reference value counts as 0, so it
                    // cannot give a NaN score that would sort first.
                    let r = (finite(r[0]) + finite(r[1]) + finite(r[2])) / 3.0;
                    let pixel = spec.crop_offset.as_ivec2() + IVec2::new(x as i32, y as i32);
                    for index in 0..settings.spp {
                        let (mut sampler, _, ray) =
                            camera_sample(camera, settings, pixel, w as u64, index);
                        let l = integrator.li_traced(scene, &ray, &mut sampler, &mut trace);
                        let l = if l.is_finite() { l } else { Default::default() };
                        let value = l.element_sum() as f64 / 3.0;
                        let score = (value - r).powi(2) / (r * r + epsilon);
                        total += score;
                        let worst_kept = best.last().map_or(f64::NEG_INFINITY, |f| f.score);
                        if best.len() < count || score > worst_kept {
                            let at = best.partition_point(|f| f.score >= score);
                            best.insert(
                                at,
                                Firefly {
                                    pixel: [pixel.x as u32, pixel.y as u32],
                                    sample_index: index,
                                    value: value as f32,
                                    reference: r as f32,
                                    score,
                                    trace: trace.clone(),
                                },
                            );
                            best.truncate(count);
                        }
                    }
                }
                (best, total)
            })
            .collect()
    });
    let total: f64 = rows.iter().map(|r| r.1).sum();
    let mut fireflies: Vec<Firefly> = rows.into_iter().flat_map(|r| r.0).collect();
    // Stable: equal scores stay in row order, so any thread count gives the same list.
    fireflies.sort_by(|a, b| b.score.total_cmp(&a.score));
    fireflies.truncate(count);
    let top: f64 = fireflies.iter().map(|f| f.score).sum();
    let pixels = w as f64 * h as f64;
    let spp = settings.spp as f64;
    Ok(FireflyReport {
        samples: (pixels * spp) as u64,
        spp: settings.spp,
        total_score: total,
        implied_rel_mse: total / (pixels * spp * spp),
        top_share: if total > 0.0 { top / total } else { 0.0 },
        fireflies,
    })
}
