#!/usr/bin/env bash
# Bit-for-bit behaviour check between two focal binaries (issue 45, "Behaviour stays"): renders each
# scene with the path tracer, the octree and the GMM at a fixed seed and spp with both binaries and
# compares the EXRs byte for byte.
#
# Usage: [COMBINE=variance] bench/bitwise_check.sh BASE_BIN NEW_BIN OUT_DIR [SPP] [RES]
# Example (base built in a worktree of the commit before the change):
#   bench/bitwise_check.sh /tmp/redesign-base/target/release/focal target/release/focal /tmp/bitwise 16 64
set -u
base=$1 new=$2 out=$3 spp=${4:-16} res=${5:-64}
mkdir -p "$out"
scenes="scenes/obscura.xml scenes/shaded_lights.xml scenes/lens_focus.xml"
status=0
for scene in $scenes; do
  name=$(basename "$scene" .xml)
  for method in path octree gmm; do
    # --combine last: before 82e74b9 the variance combination weighed iterations by their measured
    # seconds, so a guided image was not reproducible from run to run on a base older than that.
    if [ "$method" = path ]; then args=(--integrator path); else args=(--guiding "$method" --combine "${COMBINE:-last}"); fi
    for side in base new; do
      bin=$base; [ "$side" = new ] && bin=$new
      "$bin" render "$scene" -D res="$res" --spp "$spp" --seed 7 -q "${args[@]}" \
        -o "$out/${name}_${method}_${side}.exr" > "$out/${name}_${method}_${side}.log" 2>&1 \
        || { echo "$name $method: $side render FAILED (see $out/${name}_${method}_${side}.log)"; status=1; }
    done
    if cmp -s "$out/${name}_${method}_base.exr" "$out/${name}_${method}_new.exr"; then
      echo "$name $method: identical ($(sha256sum < "$out/${name}_${method}_new.exr" | cut -c1-16))"
    else
      echo "$name $method: DIFFERENT"; status=1
    fi
  done
done
exit $status
