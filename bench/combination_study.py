#!/usr/bin/env python3
"""Compares rules for combining a guided render's iterations on the same renders (paired).

Needs numpy and OpenEXR (`pip install numpy OpenEXR`), and the benchmark's references
(`python3 bench/benchmark.py truth`). Renders come from `focal render ... --no-fallback --save-iterations
DIR -o DIR.exr`, named SCENE_METHOD_SEED (SCENE as in bench/benchmark.py):

  python3 bench/combination_study.py RUNS_DIR [--rules last,old,raised_third,...]

Each rule turns the saved iterations (two halves each, with spp from the sidecar) into an
image, which is scored as the benchmark scores (bench/benchmark.py, crates/render/src/eval/score.rs): the
untrimmed exposure-normalised relMSE against the truth from both references, and the bias check. Since every
rule sees the same iterations, the per-seed ratios between rules are paired and far less noisy than
separate renders.

Rules:
  last          the final iteration only (Rath et al.)
  old           until 2026-12-07: guided iterations with at least a quarter of the largest one's spp,
                weighted 1/v, those under 5 % of the best weight dropped
  raised_all    1/v with each iteration's inefficiency v·n (n its samples per pixel) raised to at least the
                final one's (all guided)
  raised_third  the same over the final iteration and the last third of the guided training (the default)
  later_third   as raised_third, but raised to the largest of the later iterations' (the first version)
  samples_third sample-count weights over the final iteration and the last third of the guided training
"""

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import OpenEXR

sys.path.insert(0, str(Path(__file__).resolve().parent))
import benchmark  # noqa: E402

EPS = 1e-2


def load(path):
    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.array(ch["RGB"].pixels, dtype=np.float64)
        return np.stack([np.array(ch[c].pixels, dtype=np.float64) for c in "RGB"], -1)


def brightness(img):
    return img.mean(-1)


def rel_eps(pooled):
    m = brightness(pooled).mean()
    return EPS * m * m if m > 0 else EPS


def halves_variance(it, pooled):
    """Relative variance v of one iteration's image (None below 2 spp)."""
    (a, na), (b, nb) = it["a"], it["b"]
    if na == 0 or nb == 0:
        return None
    scale = 1.0 / (1.0 / na + 1.0 / nb)
    d2 = ((a - b) ** 2).mean(-1) * scale
    m = brightness(pooled)
    v = (d2 / (m * m + rel_eps(pooled))).mean()
    return v / (na + nb)


def image(it):
    (a, na), (b, nb) = it["a"], it["b"]
    n = na + nb
    return a * (na / n) if nb == 0 else (a * na + b * nb) / n


def pooled(its):
    n = sum(i["spp"] for i in its)
    return sum(image(i) * (i["spp"] / n) for i in its)


def raised_weights(its, to_later=False):
    p = pooled(its)
    known = []
    for it in its:
        v = halves_variance(it, p)
        e = v * max(it["spp"], 1e-9) if v is not None else None
        known.append(e if e is not None and e > 0 and math.isfinite(e) else None)
    worst = max([e for e in known if e is not None], default=0.0)
    if worst <= 0:
        t = [max(i["spp"], 0.0) for i in its]
        return [x / sum(t) for x in t]
    last = known[-1] if known[-1] is not None else worst
    raised = [max(e if e is not None else worst, last) for e in known]
    if to_later:
        # the first version: raised to the largest of the later iterations'
        raised, later = [0.0] * len(known), 0.0
        for i in reversed(range(len(known))):
            later = max(later, known[i] if known[i] is not None else worst)
            raised[i] = later
        last = raised[-1]
    w = [max(it["spp"], 1e-9) / r if r <= 20 * last else 0.0 for it, r in zip(its, raised)]
    s = sum(w)
    return [x / s for x in w]


def old_weights(its):
    p = pooled(its)
    top = max(i["spp"] for i in its)
    w = []
    for it in its:
        v = halves_variance(it, p) if it["spp"] >= 0.25 * top else None
        w.append(0.0 if v is None else (1.0 / v if v > 0 else 1e300))
    best = max(w)
    if best <= 0:
        return [0.0] * (len(its) - 1) + [1.0]
    w = [x if x >= 0.05 * best else 0.0 for x in w]
    s = sum(w)
    return [x / s for x in w]


def stable(its):
    """The final iteration and the last third of the guided training iterations."""
    train = [i for i in its if i["training"]]
    keep = max(1, math.ceil(len(train) / 3))
    return train[len(train) - keep:] + [i for i in its if not i["training"]]


def combine(rule, its):
    guided = [i for i in its if i["guided"]]
    if rule == "last":
        chosen, w = [guided[-1]], [1.0]
    elif rule == "old":
        chosen = guided
        w = old_weights(chosen)
    elif rule == "raised_all":
        chosen = guided
        w = raised_weights(chosen)
    elif rule == "raised_third":
        chosen = stable(guided)
        w = raised_weights(chosen)
    elif rule == "later_third":
        chosen = stable(guided)
        w = raised_weights(chosen, to_later=True)
    elif rule == "samples_third":
        chosen = stable(guided)
        t = [i["spp"] for i in chosen]
        w = [x / sum(t) for x in t]
    else:
        sys.exit(f"unknown rule {rule}")
    return sum(image(i) * x for i, x in zip(chosen, w) if x > 0)


def score(img, a, b):
    t = 0.5 * (a + b)
    tb = brightness(t).mean()
    eps = EPS * tb * tb
    norm = t * t + eps
    rel = ((img - a) * (img - b) / norm).mean()
    black = (a * b / norm).mean()

    def trimmed(x):
        v = np.sort(brightness(x).ravel())
        k = int(math.floor(v.size * 1e-3))
        return v[: v.size - k].mean()

    ratio = trimmed(img) / trimmed(t)
    return dict(rel=rel, black=black, trimmed=ratio, failed=abs(ratio - 1) > 0.3)


def load_run(sidecar):
    d = json.loads(sidecar.read_text())
    folder = sidecar.with_suffix("")
    its = []
    for s in d["iterations"]:
        if s["spp"] == 0:
            continue
        k = s["index"]
        a = folder / f"iteration_{k:02d}_a.exr"
        b = folder / f"iteration_{k:02d}_b.exr"
        ha = (load(a), s["spp"] - s["spp"] // 2) if a.exists() else (None, 0)
        hb = (load(b), s["spp"] // 2) if b.exists() else (None, 0)
        if hb[0] is None:
            ha = (ha[0], s["spp"])
        its.append(dict(a=ha, b=hb, spp=s["spp"], t=s["render_s"], guided=s["guided"],
                        training=s["training"]))
    return its


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs")
    p.add_argument("--rules", default="last,old,raised_all,raised_third,later_third,samples_third")
    args = p.parse_args()
    rules = args.rules.split(",")
    results = {}
    for side in sorted(Path(args.runs).glob("*.json")):
        # SCENE_METHOD_SEED, or bench/benchmark.py's STAGE[-TAG]_SCENE_METHOD_SEED
        scene, method, seed = side.stem.rsplit("_", 3)[-3:]
        if not side.with_suffix("").is_dir():
            continue
        try:
            ra, rb = (load(r) for r in benchmark.reference_paths(scene))
        except Exception as e:  # noqa: BLE001
            print(f"{side.stem}: no truth ({e})", file=sys.stderr)
            continue
        its = load_run(side)
        results.setdefault((scene, method), []).append({r: score(combine(r, its), ra, rb) for r in rules})
    print(f"{'scene':8} {'method':6} {'n':>2} " + " ".join(f"{r:>22}" for r in rules))
    for (scene, method), runs in sorted(results.items()):
        cells = []
        for r in rules:
            mean = sum(x[r]["rel"] for x in runs) / len(runs)
            paired = math.exp(sum(math.log(max(x[r]["rel"], 1e-30) / max(x["last"]["rel"], 1e-30))
                                  for x in runs) / len(runs)) if "last" in rules else float("nan")
            fails = sum(x[r]["failed"] for x in runs)
            cells.append(f"{mean:9.3g} x{paired:5.2f} f{fails}")
        print(f"{scene:8} {method:6} {len(runs):2d} " + " ".join(f"{c:>22}" for c in cells))
    print("(mean relMSE over seeds, per-seed geometric mean of the ratio to `last`, failures)")


if __name__ == "__main__":
    main()
