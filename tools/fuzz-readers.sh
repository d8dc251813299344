#!/usr/bin/env bash
# Long, benchmark-style fuzzing run of the scene XML and OBJ/PLY/serialized readers (byte mutations via
# proptest; see crates/render/tests/fuzz_readers.rs). The regular test suite runs 48 cases per reader.
# Usage: tools/fuzz-readers.sh [CASES_PER_READER]   (default 20000: a few minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
FOCAL_FUZZ_CASES="${1:-20000}" exec cargo test --release -p focal-render --test fuzz_readers -- --test-threads=2
