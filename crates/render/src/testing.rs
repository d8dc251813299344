//! Locations of the shared test data (the Mitsuba scene corpus, the reference scenes and renders).
//!
//! The data lives outside the repository, in a `shared/` folder beside the checkout (CI clones the repo
//! with `shared/` next to it; developer worktrees may sit deeper), so tests find it through this helper.

use std::path::PathBuf;

/// The shared data folder: `$FOCAL_SHARED` if set, else `<repo>/../shared`, else `/work/shared`.
/// Returns the last candidate even when none exists, so that a test fails naming a concrete path.
pub fn shared_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("FOCAL_SHARED") {
        return PathBuf::from(dir);
    }
    let beside_repo = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"));
    if beside_repo.is_dir() {
        return beside_repo;
    }
    PathBuf::from("/work/shared")
}
