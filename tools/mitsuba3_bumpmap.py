#!/usr/bin/env python3
"""Makes the data of focal's bump-map test (crates/render/tests/bumpmap_render.rs): the height field and
Mitsuba 3's converged render of crates/render/tests/data/bumpmap/scene.xml.

    pip install mitsuba
    python3 tools/mitsuba3_bumpmap.py [--spp 1024] [--variant llvm_ad_rgb]
"""
import argparse
import os

import numpy as np
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "crates", "render", "tests", "data", "bumpmap")


def write_height(path, size=32):
    """Ridges along v and a bump pattern along u and v, values in [0, 1], as linear RGB floats."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    h = 0.5 + 0.3 * np.sin(2 * np.pi * 3 * x) + 0.2 * np.sin(2 * np.pi * 2 * (x + y))
    h = np.clip(h, 0.0, 1.0).astype(np.float32)
    mi.Bitmap(np.repeat(h[:, :, None], 3, axis=2), pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    args = ap.parse_args()
    try:
        mi.set_variant(args.variant)
    except Exception:
        mi.set_variant("scalar_rgb")
    write_height(os.path.join(DATA, "height.exr"))
    scene = mi.load_file(os.path.join(DATA, "scene.xml"), spp=str(args.spp))
    img = mi.render(scene, spp=args.spp, seed=7)
    out = os.path.join(DATA, f"mitsuba3_{args.spp}spp.exr")
    mi.Bitmap(img).write(out)
    arr = np.array(img)
    print(f"{out}: mean {arr.reshape(-1, arr.shape[-1]).mean(axis=0)}, variant {mi.variant()}")


if __name__ == "__main__":
    main()
