//! Helpers shared by the command-line tool's integration tests.
#![allow(dead_code)] // each test binary uses some of these

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `focal` binary with `args` and returns its output, failing the test (with its stderr) if
/// it does not exit successfully.
pub fn focal(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "focal {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The bundled Cornell box, the tests' small scene.
pub fn cbox() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cbox.xml")
}
