//! The render loop: runs an integrator over the film in parallel, in passes of whole-image samples.
//!
//! Determinism: sample `i` of pixel `p` always draws from the same random stream (a function of the seed,
//! `p` and `i`), tiles are fixed, and tile blocks are merged into the film in tile order, so a fixed seed
//! and sample count give a bit-identical image whatever the number of threads.

pub mod cancel;
pub mod combine;
pub mod cross_check;
pub mod fallback;
pub mod guided;
pub mod iteration;
pub mod memory;
pub mod pixel_weights;
pub mod reference;

use self::cancel::CancelFlag;
use crate::camera::Camera;
use crate::color::Rgb;
use crate::film::{AovSample, Film, FilmSpec, Image, ImageBlock};
use crate::integrator::{FirstHitAovs, GuidedPathIntegrator, Integrator};
use crate::sampler::{Sampler, SamplerKind};
use crate::scene::Scene;
use focal_guiding::TrainingSegment;
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
    /// Raised to stop at the next pass boundary (a pass under way is dropped; see [`cancel`]).
    pub cancel: CancelFlag,
    /// Index of the first sample of every pixel: a render draws the random streams of sample indices
    /// `first_sample ..`, so the shards of one render (each `first_sample = i · spp`) draw disjoint
    /// streams and together draw those of one render of all their samples.
    pub first_sample: u32,
    /// Add the film's filter weights to single-film images ([`crate::film::FILTER_WEIGHT_LAYER`]), so
    /// that shards merge exactly.
    pub filter_weights: bool,
}

impl Default for RenderSettings {
    /// One sample per pixel, seed 0, all cores, independent samples, no AOVs.
    fn default() -> Self {
        RenderSettings {
            spp: 1,
            time_limit: None,
            seed: 0,
            threads: 0,
            aovs: false,
            sampler: SamplerKind::Independent,
            cancel: CancelFlag::default(),
            first_sample: 0,
            filter_weights: false,
        }
    }
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

/// What one tile of one pass produced: its image blocks (one, or two interleaved halves) and the training
/// segments its paths recorded, in pixel and sample order.
struct TileOutput {
    blocks: Vec<ImageBlock>,
    segments: Vec<TrainingSegment>,
}

/// The sampler (after the camera's dimensions), film position and camera ray of sample `index` of
/// `pixel` on a film window `width` pixels wide: what every render of these settings draws (a pixel's
/// random streams are numbered y·width + x).
pub(crate) fn camera_sample(
    camera: &Camera,
    settings: &RenderSettings,
    pixel: IVec2,
    width: u64,
    index: u32,
) -> (Sampler, glam::Vec2, crate::ray::CameraRay) {
    let pixel_index = pixel.y as u64 * width + pixel.x as u64;
    let mut sampler = Sampler::new(settings.sampler, settings.seed, pixel_index, index);
    let film_pos = pixel.as_vec2() + sampler.next_2d();
    let aperture = sampler.next_2d();
    let mut ray = camera.generate_ray_differential(film_pos, aperture);
    // Mitsuba 0.6 shrinks the pixel footprint with the sample density: 1/√spp of a pixel.
    let amount = 1.0 / (settings.spp.max(1) as f32).sqrt();
    ray.differential = ray.differential.map(|d| d.scaled(&ray.ray, amount));
    (sampler, film_pos, ray)
}

/// A pool of `threads` workers (0: one per core) and its size.
pub(crate) fn thread_pool(threads: usize) -> (rayon::ThreadPool, usize) {
    let threads = if threads == 0 { num_cpus() } else { threads };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    (pool, threads)
}

/// One camera sample's radiance estimate (appending the training segments it records, if any): what a
/// pass evaluates per sample.
trait SampleEstimator:
    Fn(&crate::ray::CameraRay, &mut Sampler, &mut FirstHitAovs, &mut Vec<TrainingSegment>) -> Rgb + Sync
{
}

impl<F> SampleEstimator for F where
    F: Fn(
            &crate::ray::CameraRay,
            &mut Sampler,
            &mut FirstHitAovs,
            &mut Vec<TrainingSegment>,
        ) -> Rgb
        + Sync
{
}

/// Renders samples `[first, first + count)` of every pixel of one tile into fresh blocks; with two films,
/// even sample indices go to the first and odd ones to the second.
#[allow(clippy::too_many_arguments)]
fn render_tile<E: SampleEstimator>(
    camera: &Camera,
    estimator: &E,
    films: &[Film],
    settings: &RenderSettings,
    tile: (IVec2, UVec2),
    first: u32,
    index_offset: u32,
    count: u32,
    pixel_weights: Option<&[f32]>,
) -> TileOutput {
    let (offset, size) = tile;
    let mut blocks: Vec<ImageBlock> = films.iter().map(|f| f.create_block(offset, size)).collect();
    let mut segments = Vec::new();
    let width = films[0].width() as u64;
    for py in 0..size.y as i32 {
        for px in 0..size.x as i32 {
            let pixel = offset + IVec2::new(px, py);
            let recorded = segments.len();
            for s in first..first + count {
                let index = s.wrapping_add(index_offset);
                let (mut sampler, film_pos, ray) =
                    camera_sample(camera, settings, pixel, width, index);
                let mut aovs = FirstHitAovs::default();
                let l = estimator(&ray, &mut sampler, &mut aovs, &mut segments);
                let aov = AovSample {
                    albedo: aovs.albedo,
                    normal: aovs.normal,
                    depth: aovs.depth,
                };
                let half = s as usize % blocks.len();
                blocks[half].put(film_pos, l, settings.aovs.then_some(&aov));
            }
            // All of this pixel's samples share its weight: set once, after them.
            if let Some(w) = pixel_weights {
                let crop = pixel - films[0].spec().crop_offset.as_ivec2();
                let local =
                    crop.y as usize * films[0].spec().crop_size.x as usize + crop.x as usize;
                let weight = w.get(local).copied().unwrap_or(1.0);
                for seg in &mut segments[recorded..] {
                    seg.pixel_weight = weight;
                }
            }
        }
    }
    TileOutput { blocks, segments }
}

/// A film (or two interleaved half-films) being rendered in passes on a fixed thread pool: the building
/// block of plain renders ([`render`]) and of iterated, guided renders, which need to act between passes.
pub struct PassRunner<'a> {
    scene: &'a Scene,
    camera: &'a Camera,
    settings: RenderSettings,
    pool: rayon::ThreadPool,
    threads: usize,
    films: Vec<Film>,
    tiles: Vec<(IVec2, UVec2)>,
    spp_done: u32,
    passes: u32,
    index_offset: u32,
    pixel_weights: Option<Vec<f32>>,
}

impl<'a> PassRunner<'a> {
    /// A runner with empty films. `halves`: keep even and odd sample indices on separate films, so the
    /// image's variance can be estimated from their difference.
    pub fn new(
        scene: &'a Scene,
        camera: &'a Camera,
        spec: &FilmSpec,
        settings: &RenderSettings,
        halves: bool,
    ) -> Self {
        let (pool, threads) = thread_pool(settings.threads);
        let n = if halves { 2 } else { 1 };
        PassRunner {
            scene,
            camera,
            settings: settings.clone(),
            pool,
            threads,
            films: (0..n)
                .map(|_| Film::new(spec.clone(), settings.aovs))
                .collect(),
            tiles: tiles(spec),
            spp_done: 0,
            passes: 0,
            index_offset: settings.first_sample,
            pixel_weights: None,
        }
    }

    /// The runner's samples draw from the random streams of sample indices `first_sample + offset + i`
    /// rather than `first_sample + i` ([`RenderSettings::first_sample`]): the iterations of a guided render use disjoint streams, so their images are independent
    /// (with the same streams, two iterations would share camera rays and first bounces, and their
    /// combination and variance estimates would assume an independence they lack).
    pub fn with_index_offset(mut self, offset: u32) -> Self {
        self.index_offset = self.settings.first_sample.wrapping_add(offset);
        self
    }

    /// Training segments recorded from now on carry these per-pixel weights (crop-window pixels in row
    /// order; see [`TrainingSegment::pixel_weight`]); `None` leaves them at 1.
    pub fn set_pixel_weights(&mut self, weights: Option<Vec<f32>>) {
        self.pixel_weights = weights;
    }

    /// Worker threads.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Pixels of the crop window.
    pub fn pixels(&self) -> u64 {
        let s = self.films[0].spec().crop_size;
        s.x as u64 * s.y as u64
    }

    /// Samples per pixel rendered so far.
    pub fn spp_done(&self) -> u32 {
        self.spp_done
    }

    /// Passes rendered so far.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The films (one, or the even and odd halves).
    pub fn films(&self) -> &[Film] {
        &self.films
    }

    /// Empties the films but keeps the sample index, so the next pass continues the same random streams:
    /// a caller that keeps its own running total can look at each pass on its own.
    pub fn clear_films(&mut self) {
        for f in &mut self.films {
            f.clear();
        }
    }

    /// Continues a render from a checkpoint: the next pass renders sample indices from `spp_done`
    /// (the films are left as they are; restore them separately if needed).
    pub fn resume_at(&mut self, spp_done: u32, passes: u32) {
        self.spp_done = spp_done;
        self.passes = passes;
    }

    /// Runs `f` on this runner's thread pool (e.g. a guide's update, so it uses the same threads).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.pool.install(f)
    }

    /// True once the render was asked to stop ([`RenderSettings::cancel`]).
    pub fn cancelled(&self) -> bool {
        self.settings.cancel.is_set()
    }

    /// Renders samples `[spp_done, spp_done + count)` of every pixel with `integrator`. `on_tile` is
    /// called from worker threads with the number of pixel samples each tile finished. If the render is
    /// asked to stop ([`Self::cancelled`]) before or during the pass, the pass is dropped whole: nothing
    /// is added.
    pub fn run_pass(
        &mut self,
        integrator: &dyn Integrator,
        count: u32,
        on_tile: &(dyn Fn(u64) + Sync),
    ) {
        let scene = self.scene;
        self.run_tiles(
            &|ray, sampler, aovs, _| integrator.li(scene, ray, sampler, aovs),
            count,
            on_tile,
        );
    }

    /// [`Self::run_pass`] with the guided integrator recording training segments, which it returns in
    /// tile, pixel and sample order (deterministic for any thread count; none if the pass was dropped).
    pub fn run_recording_pass(
        &mut self,
        integrator: &GuidedPathIntegrator<'_>,
        count: u32,
        on_tile: &(dyn Fn(u64) + Sync),
    ) -> Vec<TrainingSegment> {
        let scene = self.scene;
        self.run_tiles(
            &|ray, sampler, aovs, training| {
                integrator.li_recording(scene, ray, sampler, aovs, training)
            },
            count,
            on_tile,
        )
    }

    fn run_tiles<E: SampleEstimator>(
        &mut self,
        estimator: &E,
        count: u32,
        on_tile: &(dyn Fn(u64) + Sync),
    ) -> Vec<TrainingSegment> {
        let first = self.spp_done;
        let index_offset = self.index_offset;
        let (camera, films, settings, tiles) =
            (self.camera, &self.films, &self.settings, &self.tiles);
        let pixel_weights = self.pixel_weights.as_deref();
        if self.cancelled() {
            return Vec::new();
        }
        let outputs: Vec<Option<TileOutput>> = self.pool.install(|| {
            tiles
                .par_iter()
                .map(|&tile| {
                    if settings.cancel.is_set() {
                        return None;
                    }
                    let out = render_tile(
                        camera,
                        estimator,
                        films,
                        settings,
                        tile,
                        first,
                        index_offset,
                        count,
                        pixel_weights,
                    );
                    on_tile(tile.1.x as u64 * tile.1.y as u64 * count as u64);
                    Some(out)
                })
                .collect()
        });
        let Some(outputs) = outputs.into_iter().collect::<Option<Vec<TileOutput>>>() else {
            return Vec::new();
        };
        let mut segments = Vec::with_capacity(outputs.iter().map(|o| o.segments.len()).sum());
        for out in outputs {
            for (film, block) in self.films.iter_mut().zip(&out.blocks) {
                film.merge_block(block);
            }
            segments.extend_from_slice(&out.segments);
        }
        self.spp_done += count;
        self.passes += 1;
        segments
    }

    /// The developed image of all samples so far (with a single film and
    /// [`RenderSettings::filter_weights`], with its filter weights as a layer).
    pub fn develop(&self) -> Image {
        if self.films.len() == 1 {
            let mut image = self.films[0].develop();
            if self.settings.filter_weights {
                image.layers.push(self.films[0].weight_layer());
            }
            return image;
        }
        // The halves' filter weights differ per pixel only through the samples' positions, so the
        // sample-count weighted mean of the developed halves is the full image up to that noise.
        let (n0, n1) = self.half_counts();
        let mut image = self.films[0].develop();
        let total = (n0 + n1).max(1) as f64;
        image.scale(n0 as f64 / total);
        image.add_scaled(&self.films[1].develop(), n1 as f64 / total);
        image
    }

    /// The two half images (even and odd sample indices) and their sample counts per pixel; `None` without
    /// halves.
    pub fn develop_halves(&self) -> Option<[(Image, u32); 2]> {
        if self.films.len() != 2 {
            return None;
        }
        let (n0, n1) = self.half_counts();
        Some([(self.films[0].develop(), n0), (self.films[1].develop(), n1)])
    }

    fn half_counts(&self) -> (u32, u32) {
        let n = self.spp_done;
        (n.div_ceil(2), n / 2)
    }

    /// Samples rejected as NaN/Inf so far.
    pub fn rejected_samples(&self) -> u64 {
        self.films.iter().map(Film::rejected_samples).sum()
    }
}

/// Counts finished pixel samples across worker threads and reports them to a progress callback.
pub struct ProgressCounter<'a> {
    progress: &'a (dyn Fn(Progress) + Sync),
    samples_total: u64,
    start: Instant,
    done: AtomicU64,
}

impl<'a> ProgressCounter<'a> {
    /// A counter at zero for a render of `samples_total` pixel samples that started at `start`.
    pub fn new(
        progress: &'a (dyn Fn(Progress) + Sync),
        samples_total: u64,
        start: Instant,
    ) -> Self {
        ProgressCounter {
            progress,
            samples_total,
            start,
            done: AtomicU64::new(0),
        }
    }

    /// Adds `n` finished samples and reports the total.
    pub fn add(&self, n: u64) {
        let d = self.done.fetch_add(n, Ordering::Relaxed) + n;
        (self.progress)(Progress {
            samples_done: d,
            samples_total: self.samples_total,
            elapsed: self.start.elapsed(),
        });
    }
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
    let mut runner = PassRunner::new(scene, camera, spec, settings, false);
    let pixels = runner.pixels();
    let samples_total = pixels * settings.spp as u64;
    let start = Instant::now();
    let counter = ProgressCounter::new(progress, samples_total, start);
    let on_tile = |n: u64| counter.add(n);
    let deadline = settings.time_limit.map(|t| start + t);
    // Passes grow geometrically so that time-limited renders stop close to the budget and fixed-spp renders
    // spend little time merging.
    let mut pass_spp = 1u32;
    while runner.spp_done() < settings.spp && !runner.cancelled() {
        let count = pass_spp.min(settings.spp - runner.spp_done());
        let pass_start = Instant::now();
        runner.run_pass(integrator, count, &on_tile);
        match deadline {
            Some(deadline) => match next_pass_spp(pass_spp, count, pass_start, deadline) {
                Some(n) => pass_spp = n,
                None => break,
            },
            None => pass_spp = (pass_spp * 2).min(32),
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let spp = runner.spp_done();
    let stats = RenderStats {
        spp,
        seconds,
        samples_per_second: (pixels * spp as u64) as f64 / seconds.max(1e-9),
        passes: runner.passes(),
        rejected_samples: runner.rejected_samples(),
        threads: runner.threads(),
    };
    RenderOutput {
        image: runner.develop(),
        stats,
    }
}

/// The size of the next pass of a render that must end by `deadline`, given that the last pass of
/// `count` spp started at `pass_start`: about 1/8 of the remaining time, at most doubling; `None` when
/// the budget is spent or no further pass fits.
pub fn next_pass_spp(
    pass_spp: u32,
    count: u32,
    pass_start: Instant,
    deadline: Instant,
) -> Option<u32> {
    let now = Instant::now();
    if now >= deadline {
        return None;
    }
    let per_spp = (now - pass_start).as_secs_f64() / count.max(1) as f64;
    let remaining = (deadline - now).as_secs_f64();
    if per_spp > remaining {
        return None;
    }
    let fit = ((remaining / per_spp.max(1e-9)) as u32).max(1);
    Some(
        (pass_spp.saturating_mul(2))
            .min(fit)
            .min(((remaining / 8.0) / per_spp.max(1e-9)).max(1.0) as u32)
            .max(1),
    )
}

/// Number of logical cores.
pub fn num_cpus() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}
