#!/usr/bin/env python3
"""Replays fallback rules on the sidecars of guided renders made without the fallback.

A render with `--no-fallback` still runs every check (the sidecar's `iterations[].cross_check`, with the
guided vertices' moment ratio per iteration), so one set of renders tells at which check any rule would
have given guiding up. Standard library only.

  python3 bench/fallback_replay.py collect OUT_DIR [--seeds 0-7] [--scenes cbox,mis,glass,...]
  python3 bench/fallback_replay.py replay OUT_DIR

`collect` renders each scene with both guides and --no-fallback at the benchmark's budget (its scene table,
bench/benchmark.py) and keeps the sidecars; `replay` prints, per scene, how many runs each rule gives up and
at which check (0-based) on average.
"""

import argparse
import collections
import glob
import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import benchmark  # noqa: E402


def checks(sidecar):
    """Per check: the inefficiency ratio, the pooled moment ratio so far (mean of the guided training
    iterations' ratios) and the 0-based check index."""
    out, moments = [], []
    for it in sidecar.get("iterations", []):
        if it.get("guided") and it.get("training") and it.get("bsdf_moment_ratio") is not None:
            moments.append(it["bsdf_moment_ratio"])
        cc = it.get("cross_check")
        if cc:
            ratio = cc["inefficiency_ratio"]
            out.append(dict(ratio=float("inf") if ratio is None else ratio,
                            mom=sum(moments) / len(moments) if moments else None, k=len(out)))
    return out


def rule(first_decisive, first=1.0, later=2.0, gate=2.0, low=0.5):
    def gives_up(c):
        if c["k"] < first_decisive or c["ratio"] == float("inf"):
            return False
        r = c["mom"]
        if r is not None and r >= gate:
            return False
        if c["k"] == first_decisive:
            return c["ratio"] > (low if r is not None and r < 1.0 else first)
        return c["ratio"] > later
    return gives_up


def old_rule(c):
    """The rule before 2026-12-07: thresholds 0.3, 1.0 (0.5 without moment gain), then 2.0 from the first
    check on; a moment ratio of at least 2 keeps guiding."""
    r = c["mom"]
    if r is not None and r >= 2.0:
        return False
    table = [0.3, 0.5, 2.0] if r is not None and r < 1.0 else [0.3, 1.0, 2.0]
    return c["ratio"] > table[min(c["k"], 2)]


RULES = {"old": old_rule, **{f"first={k}": rule(k) for k in range(0, 6)}}


def cmd_collect(args):
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names = benchmark.scene_list(args.scenes, "full")
    for seed in benchmark.seed_list(args.seeds, "full"):
        for name in names:
            s = benchmark.SCENES[name]
            for method in ("octree", "gmm"):
                image = out / f"{name}_{method}_{seed}.exr"
                if image.with_suffix(".json").exists():
                    continue
                subprocess.run([str(benchmark.FOCAL), "render", str(s["path"]), *s["args"], "--guiding", method,
                                "--time", str(s["time"]["full"]), "--seed", str(seed), "--no-fallback", "-q",
                                "-o", str(image)], check=True, capture_output=True)
                image.unlink(missing_ok=True)


def cmd_replay(args):
    res = collections.defaultdict(lambda: collections.defaultdict(list))
    for f in sorted(glob.glob(os.path.join(args.out, "*.json"))):
        name = os.path.basename(f).split("_")[0]
        cs = checks(json.loads(Path(f).read_text()))
        for rn, r in RULES.items():
            res[name][rn].append(next((c["k"] for c in cs if r(c)), None))
    print(f"{'scene':10}" + "".join(f"{r:>14}" for r in RULES))
    for name, by in res.items():
        cells = []
        for ks in by.values():
            hit = [k for k in ks if k is not None]
            at = f"{sum(hit) / len(hit):.1f}" if hit else "-"
            cells.append(f"{len(hit)}/{len(ks)} @{at}")
        print(f"{name:10}" + "".join(f"{c:>14}" for c in cells))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect")
    c.add_argument("out")
    c.add_argument("--seeds", default="0-7")
    c.add_argument("--scenes", default="cbox,mis,glass,bidir,door,shaded")
    r = sub.add_parser("replay")
    r.add_argument("out")
    args = p.parse_args()
    cmd_collect(args) if args.cmd == "collect" else cmd_replay(args)


if __name__ == "__main__":
    main()
