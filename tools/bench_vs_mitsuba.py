#!/usr/bin/env python3
"""Side-by-side throughput: focal's path tracer against Mitsuba 3 (pip package `mitsuba`) on the same
XML scenes, same resolution, spp and thread count, interleaved in one run (these machines are noisy).

    pip install mitsuba                 # once; llvm_ad_rgb also needs libLLVM (Debian: apt-get install libllvm19)
    cargo build --release -p focal-cli
    python3 tools/bench_vs_mitsuba.py --threads 2            # the reference scenes and the interior

A scene is `PATH` or `PATH:key=value:...`; the keys are passed to both renderers as scene parameters
(`-D key=value` / `mi.load_file(path, key=value)`), `spp` is the sample count and the image size is read
from `res` (square) or `resx` and `resy`. The default, `--scenes reference`, is issue 44's set: the three
Mitsuba 3 reference scenes (Cornell box and caustic 256x256 at 64 spp, camera obscura 128x128 at 64 spp)
and the generated interior (bench/make_interior.py, 320x180, 32 spp, max depth 40), written once to
`--interior-dir`.

`--focal` takes one binary or several `name=path` pairs (an older build side by side with a new one:
every repeat runs each of them in turn). Prints median samples/s per renderer and the ratios of the
first focal binary over every other column.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = REPO / "tests" / "data"  # the vendored reference scenes


def reference_set(interior_dir):
    scenes = DATA / "references" / "scenes"
    interior = Path(interior_dir) / "interior.xml"
    if not interior.exists():
        subprocess.run([sys.executable, str(REPO / "bench" / "make_interior.py"), str(interior_dir)], check=True)
    return [f"{scenes / 'cbox.xml'}:res=256:spp=64", f"{scenes / 'caustic.xml'}:res=256:spp=64",
            f"{scenes / 'obscura.xml'}:res=128:spp=64", f"{interior}:resx=320:resy=180:spp=32"]


def parse_scene(item, default_spp, default_res):
    path, *pairs = item.split(":")
    params = dict(p.split("=", 1) for p in pairs)
    spp = int(params.pop("spp", default_spp))
    if "resx" not in params and "res" not in params:
        params["res"] = str(default_res)
    w = int(params.get("resx", params.get("res")))
    h = int(params.get("resy", params.get("res")))
    return path, params, spp, w * h


def mitsuba_rate(variant, scene, params, spp, pixels, threads):
    kwargs = ", ".join(f"{k}={v!r}" for k, v in params.items())
    warm = "img = mi.render(s, spp=spp); dr.eval(img)" if "llvm" in variant or "cuda" in variant else ""
    code = f"""
import time, mitsuba as mi, drjit as dr
mi.set_variant({variant!r})
dr.set_thread_count({threads})
spp = {spp}
s = mi.load_file({scene!r}, {kwargs})
{warm}
t = time.perf_counter(); img = mi.render(s, spp=spp, seed=1); dr.eval(img); dr.sync_thread()
print(({pixels} * spp) / (time.perf_counter() - t))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=os.path.dirname(os.path.abspath(scene)))
    if out.returncode != 0:
        return None, out.stderr.strip().splitlines()[-1] if out.stderr else "failed"
    return float(out.stdout.strip().splitlines()[-1]), None


def focal_rate(binary, scene, params, spp, threads, extra):
    with tempfile.TemporaryDirectory() as d:
        exr = os.path.join(d, "o.exr")
        args = [binary, "render", scene, "--spp", str(spp), "--threads", str(threads), "-o", exr, "-q"]
        for k, v in params.items():
            args += ["-D", f"{k}={v}"]
        subprocess.run(args + extra, check=True, capture_output=True)
        with open(os.path.join(d, "o.json")) as f:
            return json.load(f)["samples_per_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="reference",
                    help="comma-separated PATH[:key=value...] items, or 'reference' (issue 44's set)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel where a scene gives none")
    ap.add_argument("--res", type=int, default=256, help="square image size where a scene gives none")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb", help="Mitsuba variants ('' for none)")
    ap.add_argument("--focal", default=str(REPO / "target/release/focal"),
                    help="a focal binary, or comma-separated name=path pairs")
    ap.add_argument("--focal-args", default="", help="extra arguments of every focal render")
    ap.add_argument("--interior-dir", default=str(REPO / "target/bench-interior"))
    ap.add_argument("--json", help="append one JSON line per scene here")
    a = ap.parse_args()
    variants = [v for v in a.variants.split(",") if v]
    binaries = [b.split("=", 1) if "=" in b else ["focal", b] for b in a.focal.split(",")]
    items = reference_set(a.interior_dir) if a.scenes == "reference" else a.scenes.split(",")
    print(f"{a.threads} thread(s), median of {a.repeats} (Msamples/s)")
    for item in items:
        scene, params, spp, pixels = parse_scene(item, a.spp, a.res)
        columns = [name for name, _ in binaries] + variants
        rates = {c: [] for c in columns}
        errors = {}
        for _ in range(a.repeats):
            for name, binary in binaries:
                rates[name].append(focal_rate(binary, scene, params, spp, a.threads, a.focal_args.split()))
            for v in variants:
                r, err = mitsuba_rate(v, scene, params, spp, pixels, a.threads)
                if r is None:
                    errors[v] = err
                else:
                    rates[v].append(r)
        med = {k: statistics.median(v) for k, v in rates.items() if v}
        first = binaries[0][0]
        label = os.path.basename(scene) + "".join(f" {k}={v}" for k, v in params.items()) + f" {spp}spp"
        line = f"{label:<36}" + "".join(f" {k} {v / 1e6:7.3f}" for k, v in med.items())
        line += "".join(f"  {first}/{c} {med[first] / med[c]:.2f}x" for c in columns[1:] if c in med)
        print(line, flush=True)
        for v, e in errors.items():
            print(f"   {v}: {e}")
        if a.json:
            with open(a.json, "a") as f:
                f.write(json.dumps({"scene": scene, "params": params, "spp": spp, "threads": a.threads,
                                    "rates": rates, "median": med}) + "\n")


if __name__ == "__main__":
    main()
