#!/usr/bin/env bash
# Instructions per camera sample (valgrind callgrind, repeatable under load) of the path tracer and of
# guided renders with a loaded guide, on focal scenes: `bench/guided_instructions.sh BIN [SCENE...]`.
# Guides are trained once (10 s, seed 1) into target/guided-cost/ as bench/guided_cost.py does.
# Counts include loading (the guide's too) and writing; a render with 0 spp is subtracted to remove them.
set -euo pipefail
bin=$1; shift
root=$(cd "$(dirname "$0")/.." && pwd)
work=$root/target/guided-cost; mkdir -p "$work"
scenes=("$@"); [ ${#scenes[@]} -gt 0 ] || scenes=("$root"/scenes/*.xml)
out=$(mktemp -d)
count() { valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$bin" render "$@" --threads 1 -o "$out/o.exr" -q \
            2>"$out/log" >/dev/null; grep -o 'refs: *[0-9,]*' "$out/log" | tr -d ', ' | cut -d: -f2; }
res=32; spp=8
for s in "${scenes[@]}"; do
  name=$(basename "$s" .xml)
  line="$name"
  pt=$(( $(count "$s" -D res=$res --spp $spp) - $(count "$s" -D res=$res --spp 1) ))
  line+=" pt $(( pt / (res * res * (spp - 1)) ))"
  for g in gmm octree; do
    gf=$work/$name.$g.guide
    [ -f "$gf" ] || "$bin" render "$s" --guiding $g --time 10 --seed 1 --threads 2 --save-guide "$gf" -o "$out/t.exr" -q
    gi=$(( $(count "$s" -D res=$res --guiding $g --load-guide "$gf" --spp $spp) \
         - $(count "$s" -D res=$res --guiding $g --load-guide "$gf" --spp 1) ))
    line+=" $g $(( gi / (res * res * (spp - 1)) )) ($(python3 -c "print(f'{$gi/$pt:.2f}')")x)"
  done
  echo "$line (instructions per camera sample)"
done
rm -rf "$out"
