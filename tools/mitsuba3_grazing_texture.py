#!/usr/bin/env python3
"""Makes the data of focal's MIP-map test (crates/render/tests/texture_filtering.rs): the checker texture
and Mitsuba 3's converged render of crates/render/tests/data/grazing_texture/scene.xml.

Mitsuba 3 has no MIP maps: its bilinear render at many samples per pixel is the pixel-box integral of
the texture, the ground truth that MIP-mapped lookups approximate at few samples.

    pip install mitsuba
    python3 tools/mitsuba3_grazing_texture.py [--spp 4096] [--variant llvm_ad_rgb]
"""
import argparse
import os

import numpy as np
import mitsuba as mi

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "crates", "render", "tests", "data", "grazing_texture")


def write_checker(path, size=256, square=4, lo=0.1, hi=0.9):
    """A grey checkerboard of `square`-texel squares, stored raw (8-bit values lo and hi)."""
    y, x = np.mgrid[0:size, 0:size]
    on = ((x // square) + (y // square)) % 2 == 0
    img = np.where(on, hi, lo)
    img = np.round(img * 255).astype(np.uint8)
    mi.Bitmap(img[:, :, None], pixel_format=mi.Bitmap.PixelFormat.Y).write(path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    args = ap.parse_args()
    try:
        mi.set_variant(args.variant)
    except Exception:
        mi.set_variant("scalar_rgb")
    write_checker(os.path.join(DATA, "checker.png"))
    scene = mi.load_file(os.path.join(DATA, "scene.xml"), filter="bilinear", spp=str(args.spp))
    img = mi.render(scene, spp=args.spp, seed=7)
    out = os.path.join(DATA, f"mitsuba3_bilinear_{args.spp}spp.exr")
    mi.Bitmap(img).write(out)
    arr = np.array(img)
    print(f"{out}: mean {arr.reshape(-1, arr.shape[-1]).mean(axis=0)}, variant {mi.variant()}")


if __name__ == "__main__":
    main()
