//! Location of the test data vendored in the repository: the public Mitsuba scene corpus
//! (`tests/data/corpus`, each scene with its licence and attribution) and the small reference scenes with
//! their Mitsuba 3 renders (`tests/data/references`). See `tests/data/README.md`.

use std::path::PathBuf;

/// The repository's `tests/data` folder, found from this crate's manifest, so that tests run from any
/// clone without outside data.
pub fn test_data_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data"))
}
