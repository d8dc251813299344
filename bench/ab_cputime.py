#!/usr/bin/env python3
"""Paired A/B of focal binaries by CPU time (user + system, from the kernel's child accounting), which
the machine's load inflates far less than wall time: alternates the binaries `--repeats` times on each
scene and prints median CPU seconds of rendering (a 1-spp render's CPU time, loading and writing
included, is subtracted). `bench/ab_cputime.py --focal a=BIN,b=BIN --scenes "PATH:key=val:spp=N,..."`"""
import argparse, os, resource, statistics, subprocess, tempfile


def cpu(args):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(args, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


ap = argparse.ArgumentParser()
ap.add_argument("--focal", required=True)
ap.add_argument("--scenes", required=True)
ap.add_argument("--repeats", type=int, default=5)
ap.add_argument("--threads", type=int, default=1)
a = ap.parse_args()
bins = [b.split("=", 1) for b in a.focal.split(",")]
with tempfile.TemporaryDirectory() as d:
    for item in a.scenes.split(","):
        path, *pairs = item.split(":")
        params = dict(p.split("=", 1) for p in pairs)
        spp = params.pop("spp")
        base = [path, "--threads", str(a.threads), "-o", os.path.join(d, "o.exr"), "-q"]
        for k, v in params.items():
            base += ["-D", f"{k}={v}"]
        t = {n: [] for n, _ in bins}
        for _ in range(a.repeats):
            for n, b in bins:
                t[n].append(cpu([b, "render", *base, "--spp", spp]) - cpu([b, "render", *base, "--spp", "1"]))
        med = {n: statistics.median(v) for n, v in t.items()}
        first = bins[0][0]
        print(f"{os.path.basename(path)} {params} {spp} spp: "
              + " ".join(f"{n} {m:.2f} s" for n, m in med.items())
              + "".join(f"  {n}/{first} {med[n] / med[first]:.2f}x" for n in med if n != first), flush=True)
