#!/usr/bin/env python3
"""Renders scenes with two focal binaries (same seed, spp and threads) and reports whether the images are
bit-identical, else the largest and mean relative difference: `bench/same_images.py BIN_A BIN_B [--threads N]`.
Reads the EXRs with Mitsuba's Bitmap (pip install mitsuba) and numpy."""
import argparse, os, subprocess, tempfile
from pathlib import Path
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
REPO = Path(__file__).resolve().parent.parent
DATA = REPO / "tests" / "data"  # the vendored reference scenes

ap = argparse.ArgumentParser()
ap.add_argument("a"), ap.add_argument("b")
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--extra", default="", help="extra render arguments")
a = ap.parse_args()
R = DATA / "references/scenes"
scenes = [f"{R}/cbox.xml -D res=64 --spp 16", f"{R}/caustic.xml -D res=64 --spp 16",
          f"{R}/obscura.xml -D res=64 --spp 16",
          f"{REPO}/target/bench-interior/interior.xml -D resx=80 -D resy=45 --spp 8"]
scenes += [f"{p} -D res=48 --spp 8" for p in sorted((REPO / "scenes").glob("*.xml"))]
with tempfile.TemporaryDirectory() as d:
    for s in scenes:
        imgs = []
        for i, b in enumerate((a.a, a.b)):
            out = os.path.join(d, f"{i}.exr")
            subprocess.run([b, "render", *s.split(), "--seed", "5", "--threads", str(a.threads), "-o", out, "-q",
                            *a.extra.split()], check=True, capture_output=True)
            imgs.append(np.array(mi.Bitmap(out)))
        x, y = imgs
        same = np.array_equal(x, y)
        rel = np.abs(x - y) / np.maximum(np.abs(x), 1e-6)
        print(f"{Path(s.split()[0]).name:<22} {'bit-identical' if same else 'DIFFERENT'}"
              + ("" if same else f"  max rel {rel.max():.2e} mean rel {rel.mean():.2e}"), flush=True)
