#!/usr/bin/env python3
"""Equal-time benchmark of the guides over the focal and non-focal scenes (issue 4's benchmark).

Standard library only; drives the release `focal` binary. Three commands:

  refs   renders two independent references per scene (a GMM and an octree render, --combine last,
         different seeds) into DIR/refs, so that `focal metrics --second-reference` can estimate each
         run's relMSE against the true image (the caustic and the reference camera obscura use the
         Mitsuba 3 render as the first reference). Existing references are kept.
  run    renders every variant x seed x scene at equal time, interleaved per seed (so that the machine's
         drift hits every variant alike), scores each against the references and appends one JSON line
         per run to OUT (runs already in OUT are skipped, so an interrupted batch resumes).
  table  prints, per scene, each variant's mean and median relMSE and its ratio to the base variant
         (mean / median / per-seed geometric mean), and the geometric means over the focal scenes.

Variants are `name|extra arguments`, separated by `;`, e.g.
  bench/focal_bench.py run b1.jsonl --seeds 0-2 --time 10 \
      --variants "octree|--guiding octree;gmm|--guiding gmm"
  bench/focal_bench.py table b1.jsonl --base octree
A variant may name another binary with `name|@/path/to/focal|args` (an older build, side by side).
The score is the trimmed relMSE (epsilon 1e-2, the 0.1 % largest per-pixel errors left out, as
`focal metrics --outliers 0.001`) against the truth estimated from both references
(`rel_mse_two_references`); `rel_mse` (against the first reference alone) is kept too.
"""

import argparse
import json
import math
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = REPO / "tests" / "data"  # the vendored corpus and Mitsuba 3 references
FOCAL = REPO / "target" / "release" / "focal"

# name: (scene file, extra render arguments, Mitsuba 3 reference or None, focal?)
SCENES = {
    "caustic": (DATA / "references/scenes/caustic.xml", [],
                DATA / "references/mitsuba3/caustic_llvm_256px_4096spp.exr", True),
    "obscura": (DATA / "references/scenes/obscura.xml", ["-D", "res=128"],
                DATA / "references/mitsuba3/obscura_llvm_128px_16384spp.exr", True),
    "bidir": (DATA / "corpus/veach-bidir/scene.xml",
              ["--integrator", "path", "-D", "resx=128", "-D", "resy=128"], None, True),
    "torus": (DATA / "corpus/torus-v3/scene.xml",
              ["--integrator", "path", "-D", "resx=128", "-D", "resy=96"], None, True),
    "ring": (DATA / "corpus/sms-ring/ring.xml", ["--integrator", "path"], None, True),
    "ownobs": (REPO / "scenes/obscura.xml", [], None, True),
    "lens": (REPO / "scenes/lens_focus.xml", [], None, True),
    "shaded": (REPO / "scenes/shaded_lights.xml", [], None, True),
    "door": (REPO / "scenes/door_gap.xml", [], None, True),
    "glass": (REPO / "scenes/glass_caustic.xml", [], None, True),
    "cbox": (DATA / "references/scenes/cbox.xml", [],
             DATA / "references/mitsuba3/cbox_llvm_256px_1024spp.exr", False),
    "mis": (DATA / "corpus/veach-mis-mi3/integrator_direct_both.xml", ["--integrator", "path"],
            None, False),
}
FOCAL_SCENES = [name for name, s in SCENES.items() if s[3]]


def scene_list(arg):
    if not arg or arg == "focal":
        return FOCAL_SCENES
    if arg == "all":
        return list(SCENES)
    names = arg.split(",")
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        sys.exit(f"unknown scenes {unknown}; known: {', '.join(SCENES)}")
    return names


def seed_list(arg):
    seeds = []
    for part in arg.split(","):
        if "-" in part:
            a, b = part.split("-")
            seeds += range(int(a), int(b) + 1)
        else:
            seeds.append(int(part))
    return seeds


def parse_variants(arg):
    variants = []
    for item in arg.split(";"):
        item = item.strip()
        if not item:
            continue
        fields = item.split("|")
        name = fields[0]
        binary = str(FOCAL)
        rest = fields[1:]
        if rest and rest[0].startswith("@"):
            binary = rest[0][1:]
            rest = rest[1:]
        variants.append((name, binary, shlex.split(" ".join(rest))))
    return variants


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stderr}")
    return p.stdout


def reference_paths(refs, name):
    mitsuba = SCENES[name][2]
    own_a = refs / f"{name}_a.exr"
    own_b = refs / f"{name}_b.exr"
    if mitsuba is not None:
        return mitsuba, own_a
    return own_a, own_b


def cmd_refs(args):
    refs = Path(args.dir) / "refs"
    refs.mkdir(parents=True, exist_ok=True)
    for name in scene_list(args.scenes):
        path, extra, mitsuba, focal = SCENES[name]
        jobs = [("a", "gmm", 777)] if mitsuba is not None else [("a", "gmm", 777), ("b", "octree", 778)]
        for tag, method, seed in jobs:
            out = refs / f"{name}_{tag}.exr"
            if out.exists():
                continue
            guiding = ["--guiding", method, "--combine", "last"] if focal else []
            cmd = [str(FOCAL), "render", str(path), *extra, *guiding, "--time", str(args.time),
                   "--seed", str(seed), "-q", "-o", str(out)]
            t = time.time()
            run(cmd)
            print(f"{out.name}: {time.time() - t:.0f} s", flush=True)


def score(image, name, refs):
    a, b = reference_paths(refs, name)
    if not a.exists() or not b.exists():
        sys.exit(f"missing reference for {name} ({a}, {b}): run `refs` first")
    out = run([str(FOCAL), "metrics", str(image), str(a), "--outliers", "0.001", "--json",
               "--second-reference", str(b)])
    return json.loads(out)


def cmd_run(args):
    out = Path(args.out)
    work = Path(args.dir) / "runs"
    work.mkdir(parents=True, exist_ok=True)
    refs = Path(args.dir) / "refs"
    done = set()
    if out.exists():
        for line in out.read_text().splitlines():
            r = json.loads(line)
            done.add((r["scene"], r["variant"], r["seed"], r["time"]))
    variants = parse_variants(args.variants)
    scenes = scene_list(args.scenes)
    for seed in seed_list(args.seeds):
        for name in scenes:
            path, extra, _, _ = SCENES[name]
            for variant, binary, vargs in variants:
                if (name, variant, seed, args.time) in done:
                    continue
                image = work / f"{out.stem}_{name}_{variant}_{seed}.exr"
                cmd = [binary, "render", str(path), *extra, *vargs, "--time", str(args.time),
                       "--seed", str(seed), "-q", "-o", str(image)]
                run(cmd)
                side = json.loads(image.with_suffix(".json").read_text())
                m = score(image, name, refs)
                fell_back = (side.get("guiding") or {}).get("fallback") or {}
                record = {
                    "scene": name, "variant": variant, "seed": seed, "time": args.time,
                    "spp": side["spp"], "render_s": side["render_s"],
                    "rel_mse": m["rel_mse"], "rel_mse_true": m["rel_mse_two_references"],
                    "rel_mse_all": m["rel_mse_all"], "fell_back": bool(fell_back.get("fell_back")),
                    "args": vargs,
                }
                with out.open("a") as f:
                    f.write(json.dumps(record) + "\n")
                print(f"seed {seed} {name:8} {variant:10} spp {side['spp']:5} "
                      f"relMSE {m['rel_mse_two_references']:.4g} (one ref {m['rel_mse']:.4g})"
                      f"{' fell back' if record['fell_back'] else ''}", flush=True)
                if not args.keep_images:
                    for suffix in (".exr", ".json"):
                        image.with_suffix(suffix).unlink(missing_ok=True)


def geo(values):
    values = [v for v in values if v > 0 and math.isfinite(v)]
    return math.exp(sum(map(math.log, values)) / len(values)) if values else float("nan")


def cmd_table(args):
    rows = []
    for file in args.files:
        rows += [json.loads(line) for line in Path(file).read_text().splitlines() if line.strip()]
    key = args.metric
    by = {}
    for r in rows:
        by.setdefault((r["scene"], r["variant"]), {})[r["seed"]] = max(r[key], 1e-12)
    variants = list(dict.fromkeys(r["variant"] for r in rows))
    scenes = [s for s in SCENES if any(k[0] == s for k in by)]
    base = args.base or variants[0]
    print(f"{key}; ratios to '{base}' as mean / median / per-seed geometric mean (seeds both ran)")
    header = f"{'scene':8}" + "".join(f" | {v:>26}" for v in variants)
    print(header)
    print("-" * len(header))
    agg = {v: ([], [], []) for v in variants}
    for s in scenes:
        line = f"{s:8}"
        b = by.get((s, base), {})
        for v in variants:
            d = by.get((s, v), {})
            if not d:
                line += f" | {'':>26}"
                continue
            mean, med = statistics.mean(d.values()), statistics.median(d.values())
            if v == base or not b:
                line += f" | {mean:9.4g} {med:9.4g} n={len(d):<3}"
            else:
                common = [k for k in d if k in b]
                rm = mean / statistics.mean(b.values())
                rd = med / statistics.median(b.values())
                rs = geo([d[k] / b[k] for k in common]) if common else float("nan")
                line += f" | {mean:8.3g} {rm:5.2f}/{rd:4.2f}/{rs:4.2f}"
                if SCENES[s][3]:
                    agg[v][0].append(rm)
                    agg[v][1].append(rd)
                    agg[v][2].append(rs)
        print(line)
    print("-" * len(header))
    for v in variants:
        if v == base or not agg[v][0]:
            continue
        m, d, s = (geo(x) for x in agg[v])
        print(f"geometric mean over {len(agg[v][0])} focal scenes, {v}/{base}: "
              f"means {m:.3f}, medians {d:.3f}, per seed {s:.3f}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--dir", default=str(REPO / "target" / "bench"),
                   help="where references and run images live (default target/bench)")
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("refs", help="render the two references per scene")
    r.add_argument("--scenes", default="all")
    r.add_argument("--time", type=float, default=120)
    b = sub.add_parser("run", help="render and score variants at equal time")
    b.add_argument("out")
    b.add_argument("--variants", required=True)
    b.add_argument("--seeds", default="0-2")
    b.add_argument("--time", type=float, default=10)
    b.add_argument("--scenes", default="focal", help="focal (default), all, or a comma list")
    b.add_argument("--keep-images", action="store_true")
    t = sub.add_parser("table", help="tabulate runs")
    t.add_argument("files", nargs="+")
    t.add_argument("--base")
    t.add_argument("--metric", default="rel_mse_true", choices=["rel_mse_true", "rel_mse", "rel_mse_all"])
    args = p.parse_args()
    {"refs": cmd_refs, "run": cmd_run, "table": cmd_table}[args.cmd](args)


if __name__ == "__main__":
    main()
