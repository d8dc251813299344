#!/usr/bin/env python3
"""The guided path's own cost (issue 44): time per sample of a guided render with a loaded guide over the
path tracer's, per scene, side by side in one run.

    python3 bench/guided_cost.py --guides gmm,octree --spp 16 --repeats 3 \\
        --focal new=target/release/focal,base=target/ab/focal-base

For every scene (default: the focal scenes in scenes/) and guide, a guide is trained once
(`focal render SCENE --guiding G --time TRAIN --save-guide FILE`, seed 1, with the first binary) and
kept in --work; then every repeat renders, with each binary in turn, the path tracer (`--spp N`) and the
guided render with the loaded guide (`--guiding G --load-guide FILE --spp N`, splitting on as by
default, and with --no-split if --no-split is given). Prints median samples/s and the ratio of time
per sample, guided over the path tracer. Standard library only.
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def rate(binary, scene, args, threads):
    """Pixel samples per second of the render's sampling (the final iteration's for a guided render)."""
    with tempfile.TemporaryDirectory() as d:
        exr = os.path.join(d, "o.exr")
        subprocess.run([binary, "render", scene, "--threads", str(threads), "-o", exr, "-q"] + args,
                       check=True, capture_output=True)
        with open(os.path.join(d, "o.json")) as f:
            j = json.load(f)
    its = j.get("iterations")
    if its:
        return its[-1]["samples_per_s"]
    return j["samples_per_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default=",".join(str(p) for p in sorted((REPO / "scenes").glob("*.xml"))))
    ap.add_argument("--guides", default="gmm,octree")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--train", type=float, default=10.0, help="training time budget in seconds")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-split", action="store_true", help="also time the loaded guide with --no-split")
    ap.add_argument("--focal", default=str(REPO / "target/release/focal"),
                    help="a focal binary, or comma-separated name=path pairs")
    ap.add_argument("--define", action="append", default=[], help="scene parameter name=value (repeatable)")
    ap.add_argument("--work", default=str(REPO / "target/guided-cost"))
    ap.add_argument("--json", help="append one JSON line per scene and guide here")
    a = ap.parse_args()
    binaries = [b.split("=", 1) if "=" in b else ["focal", b] for b in a.focal.split(",")]
    defines = [x for d in a.define for x in ("-D", d)]
    os.makedirs(a.work, exist_ok=True)
    print(f"{a.threads} thread(s), {a.spp} spp, median of {a.repeats}: samples/s (k) and guided/PT time per sample")
    for scene in a.scenes.split(","):
        name = Path(scene).stem
        for guide in a.guides.split(","):
            gfile = os.path.join(a.work, f"{name}.{guide}.guide")
            if not os.path.exists(gfile):
                with tempfile.TemporaryDirectory() as d:
                    subprocess.run([binaries[0][1], "render", scene, "--guiding", guide, "--time", str(a.train),
                                    "--seed", "1", "--threads", str(a.threads), "--save-guide", gfile,
                                    "-o", os.path.join(d, "t.exr"), "-q"] + defines, check=True, capture_output=True)
            variants = {"pt": ["--spp", str(a.spp)],
                        guide: ["--guiding", guide, "--load-guide", gfile, "--spp", str(a.spp)]}
            if a.no_split:
                variants[guide + "-nosplit"] = variants[guide] + ["--no-split"]
            rates = {(b, v): [] for b, _ in binaries for v in variants}
            for _ in range(a.repeats):
                for bname, binary in binaries:
                    for v, args in variants.items():
                        rates[(bname, v)].append(rate(binary, scene, args + defines, a.threads))
            med = {k: statistics.median(r) for k, r in rates.items()}
            for bname, _ in binaries:
                cols = "".join(f" {v} {med[(bname, v)] / 1e3:8.1f}" for v in variants)
                ratios = "".join(f"  {v}/pt {med[(bname, 'pt')] / med[(bname, v)]:.2f}x"
                                 for v in variants if v != "pt")
                print(f"{name:<16} {guide:<7} {bname:<6}{cols}{ratios}", flush=True)
            if a.json:
                with open(a.json, "a") as f:
                    f.write(json.dumps({"scene": scene, "guide": guide, "spp": a.spp, "threads": a.threads,
                                        "rates": {f"{b}/{v}": r for (b, v), r in rates.items()}}) + "\n")


if __name__ == "__main__":
    main()
