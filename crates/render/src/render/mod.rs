//! The render loop: runs an integrator over the film in parallel, in passes of whole-image samples.
//!
//! Determinism: sample `i` of pixel `p` always draws from the same random stream (a function of the seed,
//! `p` and `i`), tiles are fixed, and tile blocks are merged into the film in tile order, so a fixed seed
//! and sample count give a bit-identical image whatever the number of threads.

use crate::camera::Camera;
use crate::film::{AovSample, Film, FilmSpec, Image, ImageBlock};
use crate::integrator::{FirstHitAovs, Integrator};
use crate::sampler::{Sampler, SamplerKind};
use crate::scene::Scene;
use glam::{IVec2, UVec2};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Edge length of the square tiles the film is split into.
pub const TILE_SIZE: u32 = 16;

/// What to render and how long.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Samples per pixel (an upper bound when `time_limit` is set).
    pub spp: u32,
    /// Stop after this much wall time (at a pass boundary; the first pass always completes).
    pub time_limit: Option<Duration>,
    /// Seed of all random streams.
    pub seed: u64,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// Record albedo, normal and depth AOVs.
    pub aovs: bool,
    /// Sample generator.
    pub sampler: SamplerKind,
}

/// Progress reported while rendering.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Samples (pixel samples) done so far.
    pub samples_done: u64,
    /// Samples planned (for a time-limited render: an estimate from the spp bound).
    pub samples_total: u64,
    /// Wall time so far.
    pub elapsed: Duration,
}

/// Statistics of a finished render.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderStats {
    /// Samples per pixel actually rendered.
    pub spp: u32,
    /// Wall time of the sampling (excluding scene loading).
    pub seconds: f64,
    /// Pixel samples per second.
    pub samples_per_second: f64,
    /// Number of passes.
    pub passes: u32,
    /// Samples rejected for being NaN/Inf (never written to the image).
    pub rejected_samples: u64,
    /// Threads used.
    pub threads: usize,
}

/// The developed image and its statistics.
pub struct RenderOutput {
    /// The image (crop window of the film).
    pub image: Image,
    /// Statistics.
    pub stats: RenderStats,
}

/// The tiles of the crop window, in a fixed order.
fn tiles(spec: &FilmSpec) -> Vec<(IVec2, UVec2)> {
    let mut out = Vec::new();
    let (ox, oy) = (spec.crop_offset.x, spec.crop_offset.y);
    let (w, h) = (spec.crop_size.x, spec.crop_size.y);
    let mut y = 0;
    while y < h {
        let mut x = 0;
        while x < w {
            let size = UVec2::new(TILE_SIZE.min(w - x), TILE_SIZE.min(h - y));
            out.push((IVec2::new((ox + x) as i32, (oy + y) as i32), size));
            x += TILE_SIZE;
        }
        y += TILE_SIZE;
    }
    out
}

/// Renders samples `[first, first + count)` of every pixel of one tile into a fresh block.
#[allow(clippy::too_many_arguments)]
fn render_tile(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    film: &Film,
    settings: &RenderSettings,
    tile: (IVec2, UVec2),
    first: u32,
    count: u32,
) -> ImageBlock {
    let (offset, size) = tile;
    let mut block = film.create_block(offset, size);
    let width = film.width() as u64;
    for py in 0..size.y as i32 {
        for px in 0..size.x as i32 {
            let pixel = offset + IVec2::new(px, py);
            let pixel_index = pixel.y as u64 * width + pixel.x as u64;
            for s in first..first + count {
                let mut sampler = Sampler::new(settings.sampler, settings.seed, pixel_index, s);
                let film_pos = pixel.as_vec2() + sampler.next_2d();
                let aperture = sampler.next_2d();
                let ray = camera.generate_ray(film_pos, aperture);
                let mut aovs = FirstHitAovs::default();
                let l = integrator.li(scene, ray, &mut sampler, &mut aovs);
                let aov = AovSample {
                    albedo: aovs.albedo,
                    normal: aovs.normal,
                    depth: aovs.depth,
                };
                block.put(film_pos, l, settings.aovs.then_some(&aov));
            }
        }
    }
    block
}

/// Renders `scene` through `camera` onto a film of `spec`. `progress` is called from worker threads.
pub fn render(
    scene: &Scene,
    camera: &Camera,
    spec: &FilmSpec,
    integrator: &dyn Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(Progress) + Sync),
) -> RenderOutput {
    let threads = if settings.threads == 0 {
        num_cpus()
    } else {
        settings.threads
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let mut film = Film::new(spec.clone(), settings.aovs);
    let tiles = tiles(spec);
    let pixels = spec.crop_size.x as u64 * spec.crop_size.y as u64;
    let samples_total = pixels * settings.spp as u64;
    let done = AtomicU64::new(0);
    let start = Instant::now();
    let mut spp_done = 0u32;
    let mut passes = 0u32;
    // Passes grow geometrically so that time-limited renders stop close to the budget and fixed-spp renders
    // spend little time merging.
    let mut pass_spp = 1u32;
    while spp_done < settings.spp {
        let count = pass_spp.min(settings.spp - spp_done);
        let first = spp_done;
        let pass_start = Instant::now();
        let blocks: Vec<ImageBlock> = pool.install(|| {
            tiles
                .par_iter()
                .map(|&tile| {
                    let b = render_tile(
                        scene, camera, integrator, &film, settings, tile, first, count,
                    );
                    let n = done.fetch_add(
                        tile.1.x as u64 * tile.1.y as u64 * count as u64,
                        Ordering::Relaxed,
                    );
                    progress(Progress {
                        samples_done: n + tile.1.x as u64 * tile.1.y as u64 * count as u64,
                        samples_total,
                        elapsed: start.elapsed(),
                    });
                    b
                })
                .collect()
        });
        for b in &blocks {
            film.merge_block(b);
        }
        spp_done += count;
        passes += 1;
        let pass_time = pass_start.elapsed();
        if let Some(limit) = settings.time_limit {
            let elapsed = start.elapsed();
            if elapsed >= limit {
                break;
            }
            // Next pass: aim at ~1/8 of the remaining time, at most doubling.
            let per_spp = pass_time.as_secs_f64() / count as f64;
            let remaining = (limit - elapsed).as_secs_f64();
            let fit = ((remaining / per_spp.max(1e-9)) as u32).max(1);
            pass_spp = (pass_spp * 2)
                .min(fit)
                .min(((remaining / 8.0) / per_spp.max(1e-9)).max(1.0) as u32)
                .max(1);
            if per_spp > remaining {
                break;
            }
        } else {
            pass_spp = (pass_spp * 2).min(32);
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let image = film.develop();
    let stats = RenderStats {
        spp: spp_done,
        seconds,
        samples_per_second: (pixels * spp_done as u64) as f64 / seconds.max(1e-9),
        passes,
        rejected_samples: film.rejected_samples(),
        threads,
    };
    RenderOutput { image, stats }
}

/// Number of logical cores.
pub fn num_cpus() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}
