#!/usr/bin/env bash
# Instruction counts (valgrind callgrind, repeatable under load) of small single-thread renders of the
# throughput benchmark's scenes, for each focal binary given: `bench/ab_instructions.sh BIN...`.
# The counts include loading and writing the EXR, the same for every binary.
set -euo pipefail
R=$(dirname "$0")/../tests/data/references/scenes
I=${INTERIOR:-$(dirname "$0")/../target/bench-interior/interior.xml}
[ -f "$I" ] || python3 "$(dirname "$0")/make_interior.py" "$(dirname "$I")"
scenes=("$R/cbox.xml -D res=128 --spp 8" "$R/caustic.xml -D res=128 --spp 8"
        "$R/obscura.xml -D res=64 --spp 16" "$I -D resx=160 -D resy=90 --spp 4")
out=$(mktemp -d)
for s in "${scenes[@]}"; do
  for bin in "$@"; do
    valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$bin" render $s --threads 1 -o "$out/o.exr" -q \
      2>"$out/log" >/dev/null
    printf '%-60s %-28s %14s\n' "$(basename ${s%% *}) ${s#* }" "$(basename "$bin")" \
      "$(grep -o 'refs: *[0-9,]*' "$out/log" | tr -d ', ' | cut -d: -f2)"
  done
done
rm -rf "$out"
