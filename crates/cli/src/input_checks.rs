//! Checks of the command line made before any work starts, so that a mistake costs no render: time
//! budgets, thread counts, output paths and the memory a film needs.

use anyhow::{bail, Context, Result};
use focal_render::render::num_cpus;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Longest accepted time budget: 10⁷ s (about 116 days). Larger values are typing mistakes (`1e20`),
/// and infinite or huge durations cannot be added to the clock.
pub const MAX_TIME_S: f64 = 1e7;

/// `--threads` above this many per core is refused: thousands of threads cost more to start than a
/// small render takes, and they cannot run faster than one per core.
pub const MAX_THREADS_PER_CORE: usize = 4;

/// A `--time` (or other seconds) argument as a duration: positive, finite and at most [`MAX_TIME_S`].
pub fn time_budget(flag: &str, seconds: f64) -> Result<Duration> {
    if !(seconds > 0.0) || !seconds.is_finite() {
        bail!("{flag} must be a positive, finite number of seconds, got {seconds}");
    }
    if seconds > MAX_TIME_S {
        bail!(
            "{flag} {seconds} is more than the longest budget focal accepts, {MAX_TIME_S:e} s \
             (about 116 days); for a long render give --spp instead"
        );
    }
    Duration::try_from_secs_f64(seconds).with_context(|| format!("{flag} {seconds}"))
}

/// Checks `--threads` (0 = one per core) against [`MAX_THREADS_PER_CORE`] times the cores.
pub fn threads(n: usize) -> Result<usize> {
    let cores = num_cpus();
    let bound = MAX_THREADS_PER_CORE * cores;
    if n > bound {
        bail!(
            "--threads {n} is more than {MAX_THREADS_PER_CORE} per core: this machine has {cores} \
             core(s), so at most {bound} (0 means one per core)"
        );
    }
    Ok(n)
}

/// Checks that a file can be written at `path` before the work that produces it: its name ends in
/// `.{ext}` (the format focal writes there) and its folder exists and is writable.
pub fn output_file(flag: &str, path: &Path, ext: &str, what: &str) -> Result<()> {
    let has_ext = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext));
    if !has_ext {
        let hint = if ext == "exr" {
            " (focal writes OpenEXR there; --png adds a tonemapped PNG beside it)"
        } else {
            ""
        };
        bail!(
            "{flag} {}: {what} is written as .{ext}, so the name must end in .{ext}{hint}",
            path.display()
        );
    }
    if path.is_dir() {
        bail!("{flag} {}: is a folder, not a file name", path.display());
    }
    writable_folder(flag, &parent_folder(path))
}

/// Checks that `path` can be written (any name): its folder exists and is writable.
pub fn output_any(flag: &str, path: &Path) -> Result<()> {
    if path.is_dir() {
        bail!("{flag} {}: is a folder, not a file name", path.display());
    }
    writable_folder(flag, &parent_folder(path))
}

/// Checks that the folder `dir` exists (or can be made, when `create`) and is writable.
pub fn output_folder(flag: &str, dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!("{flag} {}: exists and is not a folder", dir.display());
    }
    if !dir.exists() {
        // The deepest ancestor that exists must be a writable folder, so that the folder can be made.
        let mut ancestor = dir.parent();
        while let Some(a) = ancestor.filter(|a| !a.as_os_str().is_empty() && !a.exists()) {
            ancestor = a.parent();
        }
        let base = match ancestor {
            Some(a) if !a.as_os_str().is_empty() => a.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if !base.is_dir() {
            bail!(
                "{flag} {}: cannot be made, {} is not a folder",
                dir.display(),
                base.display()
            );
        }
        return writable_folder(flag, &base);
    }
    writable_folder(flag, dir)
}

/// The folder a file path lies in (`.` for a bare name).
fn parent_folder(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Errors unless `dir` is an existing folder in which a file can be created (tried with a probe file,
/// removed at once: permission bits do not tell for root or read-only mounts).
fn writable_folder(flag: &str, dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        bail!(
            "{flag}: the folder {} does not exist (create it first)",
            dir.display()
        );
    }
    let probe = dir.join(format!(".focal-write-test-{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => bail!("{flag}: cannot write in {}: {e}", dir.display()),
    }
}

/// Memory the machine has available now, in bytes (Linux: `MemAvailable` of /proc/meminfo); `None`
/// where it cannot be read.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a render whose images would need more memory than is available, before allocating them.
pub fn memory(needed: u64, what: &str) -> Result<()> {
    let Some(available) = available_memory() else {
        return Ok(());
    };
    if needed > available {
        bail!(
            "{what} would need about {} of memory, but {} are available; lower the resolution \
             (--res, or the scene's -D parameter)",
            gib(needed),
            gib(available)
        );
    }
    Ok(())
}

/// A byte count in GiB (or MiB when small), for messages.
pub fn gib(bytes: u64) -> String {
    let g = bytes as f64 / (1u64 << 30) as f64;
    if g >= 1.0 {
        format!("{g:.1} GiB")
    } else {
        format!("{:.0} MiB", bytes as f64 / (1u64 << 20) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_budgets_must_be_positive_finite_and_bounded() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e20, MAX_TIME_S * 2.0] {
            assert!(time_budget("--time", bad).is_err(), "{bad}");
        }
        assert_eq!(
            time_budget("--time", 1.5).unwrap(),
            Duration::from_millis(1500)
        );
        assert!(time_budget("--time", MAX_TIME_S).is_ok());
    }

    #[test]
    fn thread_bound_names_the_cores() {
        assert_eq!(threads(0).unwrap(), 0);
        assert_eq!(threads(num_cpus()).unwrap(), num_cpus());
        let e = threads(100_000).unwrap_err().to_string();
        assert!(e.contains(&format!("at most {}", 4 * num_cpus())), "{e}");
    }

    #[test]
    fn output_names_need_the_format_extension_and_an_existing_folder() {
        let dir = std::env::temp_dir();
        assert!(output_file("-o", &dir.join("x.exr"), "exr", "the image").is_ok());
        assert!(output_file("-o", &dir.join("x.EXR"), "exr", "the image").is_ok());
        let e = output_file("-o", &dir.join("x.png"), "exr", "the image").unwrap_err();
        assert!(e.to_string().contains(".exr"), "{e}");
        assert!(output_file("-o", &dir.join("x"), "exr", "the image").is_err());
        let e = output_file("-o", Path::new("/missing/dir/x.exr"), "exr", "the image")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/missing/dir") && e.contains("does not exist"),
            "{e}"
        );
        assert!(output_folder("-o", &dir.join("focal-new/a/b")).is_ok());
        assert!(output_folder("-o", Path::new("/proc/focal-cannot")).is_err());
    }
}
