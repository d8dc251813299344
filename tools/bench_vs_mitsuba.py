#!/usr/bin/env python3
"""Side-by-side throughput: focal's path tracer against Mitsuba 3 (pip package `mitsuba`) on the same
XML scenes, same resolution, spp and thread count, interleaved in one run (these machines are noisy).

    pip install mitsuba            # once; llvm_ad_rgb also needs libLLVM (apt-get install llvm)
    cargo build --release -p focal-cli
    python3 tools/bench_vs_mitsuba.py --scenes tests/data/references/scenes/cbox.xml,tests/data/references/scenes/caustic.xml

Prints median samples/s per renderer and the ratios focal / Mitsuba.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time


def mitsuba_rate(variant, scene, spp, res, threads):
    code = f"""
import time, mitsuba as mi, drjit as dr
mi.set_variant({variant!r})
dr.set_thread_count({threads})
s = mi.load_file({scene!r}, res={res}, spp={spp})
img = mi.render(s, spp={spp}); dr.eval(img)           # warm-up (JIT compilation for llvm)
t = time.perf_counter(); img = mi.render(s, spp={spp}, seed=1); dr.eval(img); dr.sync_thread()
print(({res}*{res}*{spp}) / (time.perf_counter() - t))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if out.returncode != 0:
        return None, out.stderr.strip().splitlines()[-1] if out.stderr else "failed"
    return float(out.stdout.strip().splitlines()[-1]), None


def focal_rate(binary, scene, spp, res, threads):
    with tempfile.TemporaryDirectory() as d:
        exr = os.path.join(d, "o.exr")
        subprocess.run([binary, "render", scene, "--spp", str(spp), "-D", f"res={res}", "--threads", str(threads),
                        "-o", exr, "-q"], check=True, capture_output=True)
        with open(os.path.join(d, "o.json")) as f:
            return json.load(f)["samples_per_s"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", required=True, help="comma-separated XML paths (must accept -D res and spp)")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb")
    ap.add_argument("--focal", default="target/release/focal")
    a = ap.parse_args()
    variants = a.variants.split(",")
    print(f"{a.res}x{a.res}, {a.spp} spp, {a.threads} thread(s), median of {a.repeats} (Msamples/s)")
    for scene in a.scenes.split(","):
        rates = {"focal": []} | {v: [] for v in variants}
        errors = {}
        for _ in range(a.repeats):
            rates["focal"].append(focal_rate(a.focal, scene, a.spp, a.res, a.threads))
            for v in variants:
                r, err = mitsuba_rate(v, scene, a.spp, a.res, a.threads)
                if r is None:
                    errors[v] = err
                else:
                    rates[v].append(r)
        med = {k: statistics.median(v) for k, v in rates.items() if v}
        line = f"{os.path.basename(scene):<14}" + "".join(f" {k} {v / 1e6:7.3f}" for k, v in med.items())
        line += "".join(f"  focal/{v} {med['focal'] / med[v]:.2f}x" for v in variants if v in med)
        print(line)
        for v, e in errors.items():
            print(f"   {v}: {e}")


if __name__ == "__main__":
    main()
