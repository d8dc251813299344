//! `--json PATH`, the same in every subcommand that has it: the JSON record goes to PATH, or to
//! standard output when PATH is `-`.

use crate::input_checks;
use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// True for the `-` that means standard output.
fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Checks before the work that a `--json` path can be written.
pub fn check(path: &Path) -> Result<()> {
    if is_stdout(path) {
        return Ok(());
    }
    input_checks::output_any("--json", path)
}

/// Writes `value`, pretty-printed, to `path` (standard output for `-`).
pub fn write(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value)? + "\n";
    if is_stdout(path) {
        // A closed pipe (`| head`) is the reader's choice, not an error worth a panic.
        let _ = std::io::stdout().lock().write_all(text.as_bytes());
        return Ok(());
    }
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}
