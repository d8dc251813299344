//! Long, resumable reference renders: an unguided render in fixed-size passes that writes a checkpoint
//! (the film's accumulators and per-pixel sums of the pass images and of their squares) atomically
//! between passes, so a killed render continues where the last checkpoint left it and ends with the
//! bit-identical image of an uninterrupted run.
//!
//! Why the result is bit-identical: sample `i` of pixel `p` always draws the same random stream (see
//! [`super`]), every pass has the same size in both runs, and the checkpoint holds the exact `f64`
//! accumulators, to which the remaining passes add the same blocks in the same order.
//!
//! The per-pixel variance of the mean comes from the passes as batch means: with pass images `x_p` of
//! `n_p` samples (`N = Σ n_p`, `P` passes), `Var(x̄) ≈ Σ n_p (x_p − x̄)² / (N (P − 1))`, which for equal
//! passes is the textbook `Σ (x_p − x̄)² / (P (P − 1))`. It needs at least two passes.

use super::{PassRunner, Progress, ProgressCounter, RenderSettings, RenderStats};
use crate::camera::Camera;
use crate::film::{Film, FilmSpec, Image, ImageLayer};
use crate::integrator::Integrator;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::io;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Name of the EXR layer holding the per-pixel variance of the mean (channels R, G, B).
pub const VARIANCE_LAYER: &str = "variance";

const CHECKPOINT_MAGIC: [u8; 8] = *b"FOCALREF";
const CHECKPOINT_VERSION: u32 = 1;

/// How a reference render runs.
#[derive(Clone, Debug)]
pub struct ReferenceSettings {
    /// Seed, threads, sampler and the total samples per pixel (`time_limit` and `aovs` are ignored).
    pub render: RenderSettings,
    /// Samples per pixel of every pass (the last one may be smaller).
    pub pass_spp: u32,
    /// Write the checkpoint after a pass once this much time has passed since the last write (zero:
    /// after every pass). The last pass is always checkpointed.
    pub checkpoint_interval: Duration,
    /// Stop (with a checkpoint) after this many passes of this run: a deliberate interruption.
    pub stop_after_passes: Option<u32>,
    /// Identifies the scene and the settings that shape the samples (scene file contents, parameters,
    /// seed, sampler, pass size); a checkpoint with another key is refused.
    pub key: u64,
}

/// Everything needed to continue a reference render.
#[derive(Serialize, Deserialize)]
struct Checkpoint {
    magic: [u8; 8],
    version: u32,
    key: u64,
    pass_spp: u32,
    width: u32,
    height: u32,
    spp_done: u32,
    passes: u32,
    seconds: f64,
    film: Vec<f64>,
    rejected: u64,
    /// Per pixel and channel: Σ n_p x_p over passes.
    sum: Vec<f64>,
    /// Per pixel and channel: Σ n_p x_p².
    sum_sq: Vec<f64>,
}

/// How a reference render ended.
pub enum ReferenceOutcome {
    /// All samples are done: the image (with its variance layer) and the statistics.
    Finished {
        /// RGB mean and the [`VARIANCE_LAYER`] layer.
        image: Image,
        /// Totals over all runs that contributed (seconds summed over runs).
        stats: RenderStats,
        /// Samples per pixel that were already done when this run started.
        resumed_from_spp: u32,
    },
    /// Stopped early on purpose (`stop_after_passes`, or asked to stop through
    /// [`RenderSettings::cancel`]); the checkpoint holds the progress.
    Stopped {
        /// Samples per pixel done so far.
        spp_done: u32,
    },
}

/// The checkpoint file of an output path: `OUT.checkpoint` beside it.
pub fn checkpoint_path(output: &Path) -> PathBuf {
    let mut p = output.as_os_str().to_owned();
    p.push(".checkpoint");
    PathBuf::from(p)
}

/// A 64-bit FNV-1a hash, stable across platforms and compiler versions (for checkpoint keys).
pub fn fnv1a64(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for &b in part.iter().chain((part.len() as u64).to_le_bytes().iter()) {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

fn invalid(path: &Path, msg: impl std::fmt::Display) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("{}: {msg}", path.display()),
    )
}

fn read_checkpoint(path: &Path) -> io::Result<Option<Checkpoint>> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    let c: Checkpoint = postcard::from_bytes(&bytes)
        .map_err(|e| invalid(path, format!("not a focal reference checkpoint: {e}")))?;
    if c.magic != CHECKPOINT_MAGIC || c.version != CHECKPOINT_VERSION {
        return Err(invalid(
            path,
            "not a focal reference checkpoint of this version",
        ));
    }
    Ok(Some(c))
}

/// Writes to a temporary file beside `path`, then renames it over `path`, so a kill at any moment leaves
/// either the old or the new checkpoint, never a torn one.
fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    {
        use std::io::Write;
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)
}

/// Renders (or continues) a reference of `scene` with an unguided `integrator`, checkpointing into
/// `checkpoint`. A checkpoint with a different key or image size is an error (delete it to start
/// over); one with more samples than asked for is an error too.
pub fn render_reference(
    scene: &Scene,
    camera: &Camera,
    spec: &FilmSpec,
    integrator: &dyn Integrator,
    settings: &ReferenceSettings,
    checkpoint: &Path,
    progress: &(dyn Fn(Progress) + Sync),
) -> io::Result<ReferenceOutcome> {
    if settings.pass_spp == 0 || settings.render.spp == 0 {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "reference renders need --spp and --pass-spp of at least 1",
        ));
    }
    let mut render_settings = settings.render.clone();
    render_settings.aovs = false;
    render_settings.time_limit = None;
    let mut runner = PassRunner::new(scene, camera, spec, &render_settings, false);
    let (w, h) = (spec.crop_size.x, spec.crop_size.y);
    let n = w as usize * h as usize * 3;
    let mut total = Film::new(spec.clone(), false);
    let mut sum = vec![0.0f64; n];
    let mut sum_sq = vec![0.0f64; n];
    let mut seconds_before = 0.0;
    let resumed_from_spp = match read_checkpoint(checkpoint)? {
        None => 0,
        Some(c) => {
            if c.key != settings.key || c.pass_spp != settings.pass_spp {
                return Err(invalid(
                    checkpoint,
                    "this checkpoint belongs to another scene, seed, sampler or pass size \
                     (delete it to start over)",
                ));
            }
            if (c.width, c.height) != (w, h) || c.sum.len() != n || c.sum_sq.len() != n {
                return Err(invalid(checkpoint, "checkpoint image size differs"));
            }
            if c.spp_done > settings.render.spp {
                return Err(invalid(
                    checkpoint,
                    format!(
                        "checkpoint already has {} spp, more than the {} asked for",
                        c.spp_done, settings.render.spp
                    ),
                ));
            }
            total
                .restore_accumulators(&c.film, c.rejected)
                .map_err(|e| invalid(checkpoint, e))?;
            sum = c.sum;
            sum_sq = c.sum_sq;
            seconds_before = c.seconds;
            runner.resume_at(c.spp_done, c.passes);
            c.spp_done
        }
    };

    let pixels = runner.pixels();
    let start = Instant::now();
    let counter = ProgressCounter::new(
        progress,
        pixels * (settings.render.spp - resumed_from_spp) as u64,
        start,
    );
    let on_tile = |k: u64| counter.add(k);
    let mut last_write = Instant::now();
    let mut passes_this_run = 0u32;
    let save = |runner: &PassRunner, total: &Film, sum: &[f64], sum_sq: &[f64]| {
        let (film, rejected) = total.accumulators();
        let c = Checkpoint {
            magic: CHECKPOINT_MAGIC,
            version: CHECKPOINT_VERSION,
            key: settings.key,
            pass_spp: settings.pass_spp,
            width: w,
            height: h,
            spp_done: runner.spp_done(),
            passes: runner.passes(),
            seconds: seconds_before + start.elapsed().as_secs_f64(),
            film: film.to_vec(),
            rejected,
            sum: sum.to_vec(),
            sum_sq: sum_sq.to_vec(),
        };
        let bytes = postcard::to_allocvec(&c).map_err(io::Error::other)?;
        write_atomically(checkpoint, &bytes)
    };
    while runner.spp_done() < settings.render.spp {
        if settings.stop_after_passes == Some(passes_this_run) || runner.cancelled() {
            save(&runner, &total, &sum, &sum_sq)?;
            return Ok(ReferenceOutcome::Stopped {
                spp_done: runner.spp_done(),
            });
        }
        let count = settings
            .pass_spp
            .min(settings.render.spp - runner.spp_done());
        runner.clear_films();
        let before = runner.spp_done();
        runner.run_pass(integrator, count, &on_tile);
        if runner.spp_done() == before {
            // Asked to stop during the pass, which was dropped: keep what the passes before it did.
            save(&runner, &total, &sum, &sum_sq)?;
            return Ok(ReferenceOutcome::Stopped {
                spp_done: runner.spp_done(),
            });
        }
        let film = &runner.films()[0];
        total.merge_film(film);
        let pass_image = film.develop();
        let weight = count as f64;
        for (i, px) in pass_image.rgb.iter().enumerate() {
            for c in 0..3 {
                let v = px[c] as f64;
                let v = if v.is_finite() { v } else { 0.0 };
                sum[i * 3 + c] += weight * v;
                sum_sq[i * 3 + c] += weight * v * v;
            }
        }
        passes_this_run += 1;
        let done = runner.spp_done() >= settings.render.spp;
        if done || last_write.elapsed() >= settings.checkpoint_interval {
            save(&runner, &total, &sum, &sum_sq)?;
            last_write = Instant::now();
        }
    }

    let mut image = total.develop();
    image.sanitize();
    let spp = runner.spp_done();
    let passes = runner.passes();
    image
        .layers
        .push(variance_layer(&sum, &sum_sq, spp, passes, w, h));
    let seconds = seconds_before + start.elapsed().as_secs_f64();
    let (_, rejected) = total.accumulators();
    Ok(ReferenceOutcome::Finished {
        image,
        stats: RenderStats {
            spp,
            seconds,
            samples_per_second: (pixels * spp as u64) as f64 / seconds.max(1e-9),
            passes,
            rejected_samples: rejected,
            threads: runner.threads(),
        },
        resumed_from_spp,
    })
}

/// The batch-means variance of the mean per pixel and channel (0 with fewer than two passes).
fn variance_layer(
    sum: &[f64],
    sum_sq: &[f64],
    spp: u32,
    passes: u32,
    w: u32,
    h: u32,
) -> ImageLayer {
    let mut layer = ImageLayer::new(VARIANCE_LAYER, &["R", "G", "B"], w, h);
    if passes >= 2 && spp > 0 {
        let n = spp as f64;
        for ((o, s), q) in layer.data.iter_mut().zip(sum).zip(sum_sq) {
            let mean = s / n;
            let v = (q - n * mean * mean).max(0.0) / (n * (passes - 1) as f64);
            *o = if v.is_finite() { v as f32 } else { 0.0 };
        }
    }
    layer
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_means_variance_matches_hand_computed_value() {
        // One pixel, channel R: passes of 2 spp with means 1 and 3 → x̄ = 2,
        // Σ n_p (x_p − x̄)² = 2·1 + 2·1 = 4, Var = 4 / (4 · 1) = 1.
        let sum = [2.0 * 1.0 + 2.0 * 3.0, 0.0, 0.0];
        let sum_sq = [2.0 * 1.0 + 2.0 * 9.0, 0.0, 0.0];
        let l = variance_layer(&sum, &sum_sq, 4, 2, 1, 1);
        assert!((l.data[0] - 1.0).abs() < 1e-6, "{:?}", l.data);
        assert_eq!(l.data[1], 0.0);
        // One pass: no estimate.
        assert_eq!(variance_layer(&sum, &sum_sq, 4, 1, 1, 1).data[0], 0.0);
    }

    #[test]
    fn fnv_key_depends_on_every_part() {
        assert_ne!(fnv1a64(&[b"ab", b"c"]), fnv1a64(&[b"a", b"bc"]));
        assert_eq!(fnv1a64(&[b"x"]), fnv1a64(&[b"x"]));
    }
}
