#!/usr/bin/env python3
"""focal's equal-time benchmark, scored so that a render that missed the light cannot win.

Standard library only; drives the release binary (target/release/focal). See docs/benchmark.md.

  python3 bench/benchmark.py all [--stage full]          the one resumable command: truth, runs, report
  python3 bench/benchmark.py truth [--scenes LIST]       the references of each scene (resumable)
  python3 bench/benchmark.py run --stage quick|full [--variants V] [--tag T]   renders and scores (resumable)
  python3 bench/benchmark.py report --stage quick|full [--tag T] [--base pt]   the tables

Every run is scored by `focal metrics --json` against the scene's two references (`score` there):
  1. bias first: a run FAILS when its image, brightest 0.1 % of pixels left out, is more than 30 % off the
     truth's mean brightness (black, or its light only in fireflies);
  2. then the error: untrimmed relMSE with ε = 1e-2 times the truth's squared mean brightness (exposure
     normalised), against the true image estimated from both references.
The report gives per scene and variant: failures, fallbacks, the mean relMSE over seeds with a bootstrap
90 % interval, the black image's relMSE, the mean image brightness over the truth's (unbiasedness check),
and secondary columns (median relMSE, the old trimmed relMSE). A variant with a failure on a scene cannot
win it.

Variants are `name|extra render arguments` separated by `;`; `name|@/path/to/focal|args` runs another
binary (side by side with an older build). Runs are interleaved per seed and scene, so drift of the
machine's speed hits every variant alike.
"""

import argparse
import json
import math
import os
import random
import shlex
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
# FOCAL_BIN pins another build (e.g. a copy, so that rebuilding during a long run changes nothing).
FOCAL = Path(os.environ.get("FOCAL_BIN", REPO / "target" / "release" / "focal"))
WORK = REPO / "target" / "benchmark"


def data_dir():
    """The public test scenes and Mitsuba 3 renders: vendored in the repository, else beside it."""
    for d in (REPO / "tests" / "data", REPO.parent / "shared"):
        if (d / "corpus").is_dir():
            return d
    return REPO / "tests" / "data"


DATA = data_dir()
SCENES_DIR = REPO / "scenes"

# Reference recipes: ("pt", spp) a plain path-traced `focal reference`; ("octree"|"gmm", train_spp, spp) a
# `focal reference` guided by a guide trained with a budget of train_spp samples per pixel (deterministic);
# ("mitsuba", path) a Mitsuba 3 render. Seeds differ between the two references and from the runs' seeds.
INTERIOR_TRUTH = [("pt", 2048), ("octree", 128, 1024)]


def scene(path, args=(), focal=True, full=30, quick=20, truth=None, group="interior"):
    return dict(path=path, args=list(args), focal=focal, time={"full": full, "quick": quick},
                truth=truth or INTERIOR_TRUTH, group=group)


SCENES = {
    # the interiors (320x180)
    "dining": scene(SCENES_DIR / "dining_room.xml"),
    "stairs": scene(SCENES_DIR / "stair_hall.xml"),
    "living": scene(SCENES_DIR / "living_room.xml"),
    "ajar": scene(SCENES_DIR / "door_ajar.xml"),
    # small focal scenes (128x128 and thereabouts)
    "caustic": scene(DATA / "references/scenes/caustic.xml", full=10, quick=10, group="focal",
                     truth=[("mitsuba", DATA / "references/mitsuba3/caustic_llvm_256px_4096spp.exr"),
                            ("octree", 256, 1024)]),
    "obscura": scene(DATA / "references/scenes/obscura.xml", ["-D", "res=128"], full=10, quick=10,
                     group="focal",
                     truth=[("mitsuba", DATA / "references/mitsuba3/obscura_llvm_128px_16384spp.exr"),
                            ("octree", 256, 1024)]),
    "bidir": scene(DATA / "corpus/veach-bidir/scene.xml",
                   ["--integrator", "path", "-D", "resx=128", "-D", "resy=128"], full=10, quick=10,
                   group="focal", truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "torus": scene(DATA / "corpus/torus-v3/scene.xml",
                   ["--integrator", "path", "-D", "resx=128", "-D", "resy=96"], full=10, quick=10,
                   group="focal", truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "ring": scene(DATA / "corpus/sms-ring/ring.xml", ["--integrator", "path"], full=10, quick=10,
                  group="focal", truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "ownobs": scene(SCENES_DIR / "obscura.xml", full=10, quick=10, group="focal",
                    truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "lens": scene(SCENES_DIR / "lens_focus.xml", full=10, quick=10, group="focal",
                  truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "shaded": scene(SCENES_DIR / "shaded_lights.xml", full=10, quick=10, group="focal",
                    truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "door": scene(SCENES_DIR / "door_gap.xml", full=10, quick=10, group="focal",
                  truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    "glass": scene(SCENES_DIR / "glass_caustic.xml", full=10, quick=10, group="focal",
                   truth=[("octree", 256, 2048), ("gmm", 256, 2048)]),
    # non-focal checks: guiding should give up and cost at most 10 %
    "cbox": scene(DATA / "references/scenes/cbox.xml", full=10, quick=10, focal=False, group="plain",
                  truth=[("mitsuba", DATA / "references/mitsuba3/cbox_llvm_256px_1024spp.exr"),
                         ("pt", 1024)]),
    # veach-mis at its native 768x512: 30 s, as its fallback was measured before (at 10 s the schedule's
    # passes are too long for more than one or two checks)
    "mis": scene(DATA / "corpus/veach-mis-mi3/integrator_direct_both.xml", ["--integrator", "path"],
                 full=30, quick=30, focal=False, group="plain", truth=[("pt", 512), ("pt", 512)]),
}

STAGES = {
    # a screen for ideas: the interiors and three small focal scenes, 4 seeds, half the budget
    "quick": dict(scenes=["dining", "stairs", "living", "ajar", "caustic", "ring", "door", "cbox", "mis"],
                  seeds=range(100, 104)),
    # the full run, for any change of a default: every scene, 8 seeds
    "full": dict(scenes=list(SCENES), seeds=range(0, 8)),
}
DEFAULT_VARIANTS = "pt|--integrator path;octree|--guiding octree;gmm|--guiding gmm"
REF_SEEDS = (0x5EED_0001, 0x5EED_0002)


def run(cmd, quiet=False):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stderr}")
    if not quiet and p.stderr.strip():
        print(p.stderr.strip(), file=sys.stderr)
    return p.stdout


def refs_dir():
    return WORK / "truth"


def reference_paths(name):
    d = refs_dir()
    out = []
    for i, recipe in enumerate(SCENES[name]["truth"]):
        if recipe[0] == "mitsuba":
            out.append(Path(recipe[1]))
        else:
            out.append(d / f"{name}_{'ab'[i]}_{recipe[0]}.exr")
    return out


def make_reference(name, i, recipe, out):
    s = SCENES[name]
    if out.exists():
        return
    seed = REF_SEEDS[i]
    base = [FOCAL, "reference", s["path"], *s["args"], "--seed", seed, "-o", out, "-q"]
    t = time.time()
    if recipe[0] == "pt":
        run([*base, "--spp", recipe[1]])
    else:
        method, train_spp, spp = recipe
        guide = out.with_suffix(".guide")
        if not guide.exists():
            tmp = out.with_suffix(".train.exr")
            run([FOCAL, "render", s["path"], *s["args"], "--guiding", method, "--spp", train_spp,
                 "--seed", seed + 17, "--save-guide", guide, "-q", "-o", tmp])
            for ext in (".exr", ".json"):
                tmp.with_suffix(ext).unlink(missing_ok=True)
        run([*base, "--spp", spp, "--load-guide", guide])
    print(f"{out.name}: {time.time() - t:.0f} s", flush=True)


def agreement(name):
    a, b = reference_paths(name)
    m = json.loads(run([FOCAL, "metrics", a, b, "--json"], quiet=True))
    if "agreement" not in m:
        m = json.loads(run([FOCAL, "metrics", b, a, "--json"], quiet=True))
    return m.get("agreement")


def cmd_truth(args):
    refs_dir().mkdir(parents=True, exist_ok=True)
    for name in scene_list(args.scenes, args.stage):
        for i, (recipe, out) in enumerate(zip(SCENES[name]["truth"], reference_paths(name))):
            if recipe[0] != "mitsuba":
                make_reference(name, i, recipe, out)
        g = agreement(name)
        if g is None:
            print(f"{name}: no variance layer in either reference", flush=True)
            continue
        verdict = "agree" if g["agree"] else "DISAGREE"
        print(f"{name}: references {verdict}: mean ratio {g['mean_ratio']:.4f} ± {g['mean_ratio_sigma']:.4f} "
              f"(z {g['image_z']:.2f}); {g['blocks_beyond_limit']}/{g['blocks']} blocks beyond 3 sigma, "
              f"largest |z| {g['max_block_z']:.2f}, mean z² {g['mean_block_z2']:.2f}", flush=True)


def scene_list(arg, stage):
    if not arg:
        return STAGES[stage]["scenes"]
    if arg in ("all",):
        return list(SCENES)
    groups = {g: [n for n, s in SCENES.items() if s["group"] == g] for g in ("interior", "focal", "plain")}
    names = []
    for part in arg.split(","):
        names += groups.get(part, [part])
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        sys.exit(f"unknown scenes {unknown}; known: {', '.join(SCENES)} (or interior, focal, plain)")
    return names


def seed_list(arg, stage):
    if not arg:
        return list(STAGES[stage]["seeds"])
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
        name, rest, binary = fields[0], fields[1:], str(FOCAL)
        if rest and rest[0].startswith("@"):
            binary, rest = rest[0][1:], rest[1:]
        variants.append((name, binary, shlex.split(" ".join(rest))))
    return variants


def results_path(stage, tag):
    return WORK / f"{stage}{'-' + tag if tag else ''}.jsonl"


def score(image, name):
    a, b = reference_paths(name)
    for r in (a, b):
        if not r.exists():
            sys.exit(f"missing reference {r}: run `truth` first")
    m = json.loads(run([FOCAL, "metrics", image, a, "--second-reference", b, "--outliers", "0.001", "--json"],
                       quiet=True))
    return m


def cmd_run(args):
    out = results_path(args.stage, args.tag)
    out.parent.mkdir(parents=True, exist_ok=True)
    work = WORK / "runs"
    work.mkdir(parents=True, exist_ok=True)
    done = set()
    if out.exists():
        for line in out.read_text().splitlines():
            r = json.loads(line)
            done.add((r["scene"], r["variant"], r["seed"]))
    variants = parse_variants(args.variants)
    scenes = scene_list(args.scenes, args.stage)
    for seed in seed_list(args.seeds, args.stage):
        for name in scenes:
            s = SCENES[name]
            budget = args.time or s["time"][args.stage]
            for variant, binary, vargs in variants:
                if (name, variant, seed) in done:
                    continue
                image = work / f"{out.stem}_{name}_{variant}_{seed}.exr"
                scene_args = list(s["args"])
                if "--integrator" in vargs and "--integrator" in scene_args:
                    # the variant's integrator replaces the scene's
                    k = scene_args.index("--integrator")
                    del scene_args[k:k + 2]
                cmd = [binary, "render", s["path"], *scene_args, *vargs, "--time", budget, "--seed", seed,
                       "-q", "-o", image]
                if getattr(args, "save_iterations", False) and "--guiding" in vargs and binary == str(FOCAL):
                    cmd += ["--save-iterations", image.with_suffix("")]
                run(cmd, quiet=True)
                side = json.loads(image.with_suffix(".json").read_text())
                m = score(image, name)
                sc = m["score"]
                fb = (side.get("guiding") or {}).get("fallback") or {}
                its = side.get("iterations") or []
                record = {
                    "scene": name, "variant": variant, "seed": seed, "time": budget, "stage": args.stage,
                    "spp": side["spp"], "render_s": side["render_s"],
                    "rel_mse": sc["rel_mse"], "black_rel_mse": sc["black_rel_mse"],
                    "mean_ratio": sc["mean_ratio"], "trimmed_mean_ratio": sc["trimmed_mean_ratio"],
                    "failed": sc["failed"],
                    "rel_mse_trimmed_old": m.get("rel_mse_two_references"),
                    "fell_back": bool(fb.get("fell_back")),
                    "final_weight": its[-1]["weight"] if its else None,
                    "args": vargs, "binary": binary,
                }
                with out.open("a") as f:
                    f.write(json.dumps(record) + "\n")
                print(f"seed {seed} {name:8} {variant:10} spp {side['spp']:5} relMSE {sc['rel_mse']:.4g} "
                      f"(black {sc['black_rel_mse']:.3g}) mean {sc['mean_ratio']:.3f} trimmed "
                      f"{sc['trimmed_mean_ratio']:.3f}{' FAILED' if sc['failed'] else ''}"
                      f"{' fell back' if record['fell_back'] else ''}", flush=True)
                if not args.keep_images:
                    # The sidecar stays beside saved iterations: bench/combination_study.py reads both.
                    kept = (".json",) if "--save-iterations" in map(str, cmd) else ()
                    for suffix in (".exr", ".json"):
                        if suffix not in kept:
                            image.with_suffix(suffix).unlink(missing_ok=True)


def bootstrap_mean_ci(values, level=0.9, rounds=2000, rng=None):
    rng = rng or random.Random(12345)
    n = len(values)
    if n == 0:
        return (float("nan"),) * 3
    means = sorted(sum(rng.choice(values) for _ in range(n)) / n for _ in range(rounds))
    lo = means[int((1 - level) / 2 * rounds)]
    hi = means[int((1 + level) / 2 * rounds) - 1]
    return sum(values) / n, lo, hi


def bootstrap_ratio_ci(a, b, level=0.9, rounds=2000):
    """Ratio of means mean(a)/mean(b) over independent resamples of a and b, with its interval."""
    rng = random.Random(54321)
    if not a or not b:
        return (float("nan"),) * 3
    ratios = []
    for _ in range(rounds):
        ma = sum(rng.choice(a) for _ in a) / len(a)
        mb = sum(rng.choice(b) for _ in b) / len(b)
        ratios.append(ma / mb if mb > 0 else float("inf"))
    ratios.sort()
    point = (sum(a) / len(a)) / (sum(b) / len(b)) if sum(b) > 0 else float("inf")
    return point, ratios[int((1 - level) / 2 * rounds)], ratios[int((1 + level) / 2 * rounds) - 1]


def median(values):
    v = sorted(values)
    n = len(v)
    return float("nan") if n == 0 else (v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2]))


def cmd_report(args):
    rows = []
    files = args.files or [results_path(args.stage, args.tag)]
    for file in files:
        rows += [json.loads(line) for line in Path(file).read_text().splitlines() if line.strip()]
    variants = []
    for r in rows:
        if r["variant"] not in variants:
            variants.append(r["variant"])
    scenes = [n for n in SCENES if any(r["scene"] == n for r in rows)]
    base = args.base if args.base in variants else variants[0]
    lines = [f"Stage {args.stage}: {len(rows)} runs; relMSE = mean over seeds of the untrimmed, exposure-"
             f"normalised relMSE against the truth, [90 % bootstrap interval]; fail = runs whose trimmed "
             f"mean brightness is more than 30 % off the truth's; fb = runs that gave guiding up.", ""]
    header = ("| scene | black | variant | runs | fail | fb | spp | relMSE [90 %] | / " + base +
              " [90 %] | mean/truth [90 %] | median relMSE | old trimmed |")
    lines += [header, "|" + "---|" * (header.count("|") - 1)]
    geo = {v: [] for v in variants}
    for name in scenes:
        by = {v: [r for r in rows if r["scene"] == name and r["variant"] == v] for v in variants}
        black = median([r["black_rel_mse"] for v in variants for r in by[v]])
        base_vals = [r["rel_mse"] for r in by[base]]
        means = {}
        for v in variants:
            rs = by[v]
            if not rs:
                continue
            vals = [r["rel_mse"] for r in rs]
            m, lo, hi = bootstrap_mean_ci(vals)
            means[v] = m
            ratio = bootstrap_ratio_ci(vals, base_vals) if v != base else (1.0, 1.0, 1.0)
            mr = bootstrap_mean_ci([r["mean_ratio"] for r in rs])
            fails = sum(r["failed"] for r in rs)
            fbs = sum(r["fell_back"] for r in rs)
            old = [r["rel_mse_trimmed_old"] for r in rs if r.get("rel_mse_trimmed_old") is not None]
            lines.append(
                f"| {name} | {black:.3g} | {v} | {len(rs)} | {fails} | {fbs} | "
                f"{sum(r['spp'] for r in rs) / len(rs):.0f} | {m:.4g} [{lo:.3g}, {hi:.3g}] | "
                f"{ratio[0]:.3g} [{ratio[1]:.3g}, {ratio[2]:.3g}] | {mr[0]:.3f} [{mr[1]:.3f}, {mr[2]:.3f}] | "
                f"{median(vals):.4g} | {median(old) if old else float('nan'):.4g} |")
            if SCENES[name]["focal"] and ratio[0] > 0 and math.isfinite(ratio[0]):
                geo[v].append(math.log(ratio[0]))
        ok = [v for v in means if not any(r["failed"] for r in by[v])]
        if ok and min(means[v] for v in ok) < 0.5 * black:
            best = min(ok, key=lambda v: means[v])
            lines.append(f"| {name} | | best without failures: **{best}** | | | | | | | | | |")
        elif ok:
            lines.append(f"| {name} | | relMSE above half the black level: failure rates only | | | | | | | | | |")
        else:
            lines.append(f"| {name} | | every variant failed at least once | | | | | | | | | |")
    lines.append("")
    for v in variants:
        if geo[v]:
            lines.append(f"geometric mean over the focal scenes of {v}/{base}: "
                         f"{math.exp(sum(geo[v]) / len(geo[v])):.3f} ({len(geo[v])} scenes)")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)

    def common(sp):
        sp.add_argument("--stage", choices=list(STAGES), default="full")
        sp.add_argument("--scenes", help="comma-separated scene names or groups (interior, focal, plain)")
        sp.add_argument("--tag", default="", help="names the results file (target/benchmark/STAGE-TAG.jsonl)")

    t = sub.add_parser("truth", help="render the references (resumable)")
    common(t)
    r = sub.add_parser("run", help="render and score the runs (resumable)")
    common(r)
    r.add_argument("--variants", default=DEFAULT_VARIANTS)
    r.add_argument("--seeds", help="e.g. 0-7 (default: the stage's)")
    r.add_argument("--time", type=float, help="override every scene's budget (seconds)")
    r.add_argument("--save-iterations", action="store_true",
                   help="guided runs also write every iteration's halves (for bench/combination_study.py "
                        "target/benchmark/runs)")
    r.add_argument("--keep-images", action="store_true")
    rep = sub.add_parser("report", help="print the tables")
    common(rep)
    rep.add_argument("files", nargs="*", help="results files (default: the stage's)")
    rep.add_argument("--base", default="pt")
    rep.add_argument("--out", help="also write the report here")
    a = sub.add_parser("all", help="truth, run and report of a stage (resumable)")
    common(a)
    a.add_argument("--variants", default=DEFAULT_VARIANTS)
    a.add_argument("--seeds")
    a.add_argument("--time", type=float)
    a.add_argument("--keep-images", action="store_true")
    a.add_argument("--base", default="pt")
    a.add_argument("--out")
    args = p.parse_args()
    if not FOCAL.exists():
        sys.exit(f"{FOCAL} not found: cargo build --release -p focal-cli")
    if args.cmd == "truth":
        cmd_truth(args)
    elif args.cmd == "run":
        cmd_run(args)
    elif args.cmd == "report":
        cmd_report(args)
    else:
        cmd_truth(args)
        cmd_run(args)
        args.files = []
        cmd_report(args)


if __name__ == "__main__":
    main()
