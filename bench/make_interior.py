#!/usr/bin/env python3
"""Writes the throughput benchmark's interior: a furnished living room of about 110 meshes (~230k
triangles) with procedural bitmap textures, as a Mitsuba 3 XML scene that both focal and Mitsuba 3 load.

    python3 bench/make_interior.py OUT_DIR        # writes OUT_DIR/interior.xml, meshes/*.obj, textures/*.png

Standard library only and deterministic (fixed seeds), so the scene is the same on every machine; nothing
it writes is committed. The room is 8 x 3 x 6 m: a wood floor, wallpapered walls with a glazed window
(open, a constant sky behind it), two ceiling panels and a floor lamp (a bright bulb inside a shade)
as lights, a rug, a table with six chairs, a sofa, shelves with about 50 books, paintings, vases, bowls,
cups and a mirror ball. Materials: textured diffuse, rough plastic with textures, smooth and rough
conductors, glass, two-sided shades. Parameters `spp`, `resx`, `resy`, `max_depth`
(default 40, as the public interior of issue 44).
"""

import math
import os
import random
import struct
import sys
import zlib


def write_png(path, w, h, pixel):
    """An 8-bit RGB PNG whose texel (x, y) is pixel(x, y) -> (r, g, b) in 0..255."""
    rows = bytearray()
    for y in range(h):
        rows.append(0)
        for x in range(w):
            rows.extend(bytes(max(0, min(255, int(c))) for c in pixel(x, y)))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(bytes(rows), 6)))
        f.write(chunk(b"IEND", b""))


def textures(out):
    rnd = random.Random(7)
    noise = [rnd.random() for _ in range(4096)]

    def n(i):
        return noise[i % 4096]

    def wood(x, y):  # planks 64 texels wide with grain
        plank = x // 64
        g = 0.5 + 0.5 * math.sin(0.35 * y + 6 * n(plank * 31) + 2.5 * math.sin(0.05 * x + plank))
        base = 0.75 + 0.25 * n(plank * 7 + y // 128)
        edge = 0.55 if x % 64 in (0, 63) else 1.0
        return [v * base * edge * (0.8 + 0.2 * g) for v in (150, 100, 60)]

    def wallpaper(x, y):
        s = math.sin(x * 2 * math.pi / 32) * math.sin(y * 2 * math.pi / 32)
        stripe = 1.0 if (x // 16) % 4 else 0.9
        return [v * stripe * (0.92 + 0.08 * s) for v in (205, 195, 170)]

    def rug(x, y):
        cx, cy = abs(x - 127.5), abs(y - 127.5)
        band = int(max(cx, cy)) // 16
        pal = [(140, 30, 35), (200, 160, 90), (40, 50, 110), (150, 120, 70)]
        c = pal[band % 4]
        return [v * (0.85 + 0.15 * n(x * 3 + y * 517)) for v in c]

    def painting(seed):
        r = random.Random(seed)
        blobs = [(r.uniform(0, 256), r.uniform(0, 256), r.uniform(20, 90),
                  [r.uniform(30, 250) for _ in range(3)]) for _ in range(7)]
        sky = [r.uniform(60, 200) for _ in range(3)]

        def px(x, y):
            c = list(sky)
            for bx, by, br, col in blobs:
                if (x - bx) ** 2 + (y - by) ** 2 < br * br:
                    c = col
            return c
        return px

    os.makedirs(os.path.join(out, "textures"), exist_ok=True)
    write_png(os.path.join(out, "textures/wood.png"), 512, 512, wood)
    write_png(os.path.join(out, "textures/wallpaper.png"), 256, 256, wallpaper)
    write_png(os.path.join(out, "textures/rug.png"), 256, 256, rug)
    for i in range(3):
        write_png(os.path.join(out, f"textures/painting{i}.png"), 256, 256, painting(100 + i))


class Mesh:
    def __init__(self):
        self.v, self.vt, self.vn, self.f = [], [], [], []

    def tri(self, a, b, c):
        self.f.append((a, b, c))

    def write(self, path):
        with open(path, "w") as f:
            f.write("".join(f"v {x:.5f} {y:.5f} {z:.5f}\n" for x, y, z in self.v))
            f.write("".join(f"vt {u:.5f} {v:.5f}\n" for u, v in self.vt))
            f.write("".join(f"vn {x:.4f} {y:.4f} {z:.4f}\n" for x, y, z in self.vn))
            if self.vn:
                f.write("".join(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n"
                                for a, b, c in ((i + 1, j + 1, k + 1) for i, j, k in self.f)))
            else:
                f.write("".join(f"f {a}/{a} {b}/{b} {c}/{c}\n"
                                for a, b, c in ((i + 1, j + 1, k + 1) for i, j, k in self.f)))


def merge(dst, src):
    """Appends mesh src (without normals) to dst."""
    base = len(dst.v)
    dst.v += src.v
    dst.vt += src.vt
    dst.f += [(a + base, b + base, c + base) for a, b, c in src.f]


def box(lo, hi, uv_scale=1.0, rot_y=0.0, pivot=None, n=1):
    """An axis-aligned box (optionally turned by rot_y about a vertical axis through pivot), each face a
    grid of n x n quads with uvs in metres times uv_scale (flat normals)."""
    m = Mesh()
    px, pz = pivot if pivot else ((lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2)
    cs, sn = math.cos(rot_y), math.sin(rot_y)

    def turn(p):
        x, z = p[0] - px, p[2] - pz
        return (px + cs * x + sn * z, p[1], pz - sn * x + cs * z)

    for axis in range(3):
        for side in (0, 1):
            u_ax, v_ax = [a for a in range(3) if a != axis]
            if side == 0:
                u_ax, v_ax = v_ax, u_ax
            base = len(m.v)
            for j in range(n + 1):
                for i in range(n + 1):
                    p = [0.0, 0.0, 0.0]
                    p[axis] = hi[axis] if side else lo[axis]
                    p[u_ax] = lo[u_ax] + (hi[u_ax] - lo[u_ax]) * i / n
                    p[v_ax] = lo[v_ax] + (hi[v_ax] - lo[v_ax]) * j / n
                    m.v.append(turn(p))
                    m.vt.append((p[u_ax] * uv_scale, p[v_ax] * uv_scale))
            for j in range(n):
                for i in range(n):
                    a = base + j * (n + 1) + i
                    m.tri(a, a + 1, a + n + 2)
                    m.tri(a, a + n + 2, a + n + 1)
    return m


def lathe(profile, center, segments=64, rings=None):
    """A surface of revolution about the vertical through center; profile is [(radius, height)] bottom to
    top, resampled to `rings` rings by linear interpolation, with smooth normals."""
    if rings:
        pts = []
        for k in range(rings + 1):
            t = k / rings * (len(profile) - 1)
            i = min(int(t), len(profile) - 2)
            f = t - i
            pts.append(tuple(a + (b - a) * f for a, b in zip(profile[i], profile[i + 1])))
        profile = pts
    m = Mesh()
    cx, cy, cz = center
    for k, (r, y) in enumerate(profile):
        r0, y0 = profile[max(k - 1, 0)]
        r1, y1 = profile[min(k + 1, len(profile) - 1)]
        dr, dy = r1 - r0, y1 - y0
        ln = math.hypot(dr, dy) or 1.0
        for s in range(segments + 1):
            a = 2 * math.pi * s / segments
            c, sn = math.cos(a), math.sin(a)
            m.v.append((cx + r * c, cy + y, cz + r * sn))
            m.vt.append((s / segments, k / (len(profile) - 1)))
            m.vn.append((dy / ln * c, -dr / ln, dy / ln * sn))
    w = segments + 1
    for k in range(len(profile) - 1):
        for s in range(segments):
            a = k * w + s
            m.tri(a, a + w, a + 1)
            m.tri(a + 1, a + w, a + w + 1)
    return m


def sphere(center, r, segments=48):
    prof = [(r * math.sin(math.pi * k / 24), -r * math.cos(math.pi * k / 24)) for k in range(25)]
    return lathe(prof, center, segments)


MATERIALS = """
    <bsdf type="diffuse" id="mat_floor"><texture type="bitmap" name="reflectance">
        <string name="filename" value="textures/wood.png"/></texture></bsdf>
    <bsdf type="diffuse" id="mat_wall"><texture type="bitmap" name="reflectance">
        <string name="filename" value="textures/wallpaper.png"/></texture></bsdf>
    <bsdf type="diffuse" id="mat_ceiling"><rgb name="reflectance" value="0.8, 0.8, 0.78"/></bsdf>
    <bsdf type="diffuse" id="mat_rug"><texture type="bitmap" name="reflectance">
        <string name="filename" value="textures/rug.png"/></texture></bsdf>
    <bsdf type="roughplastic" id="mat_varnish">
        <float name="alpha" value="0.15"/>
        <texture type="bitmap" name="diffuse_reflectance"><string name="filename" value="textures/wood.png"/></texture>
    </bsdf>
    <bsdf type="diffuse" id="mat_darkwood"><rgb name="reflectance" value="0.12, 0.07, 0.04"/></bsdf>
    <bsdf type="diffuse" id="mat_fabric"><rgb name="reflectance" value="0.25, 0.32, 0.45"/></bsdf>
    <bsdf type="diffuse" id="mat_cushion"><rgb name="reflectance" value="0.6, 0.45, 0.2"/></bsdf>
    <bsdf type="plastic" id="mat_ceramic"><rgb name="diffuse_reflectance" value="0.75, 0.72, 0.68"/></bsdf>
    <bsdf type="roughplastic" id="mat_glaze">
        <float name="alpha" value="0.08"/><rgb name="diffuse_reflectance" value="0.1, 0.35, 0.3"/></bsdf>
    <bsdf type="roughconductor" id="mat_brass"><string name="material" value="Au"/>
        <float name="alpha" value="0.2"/></bsdf>
    <bsdf type="roughconductor" id="mat_steel"><string name="material" value="Cr"/>
        <float name="alpha" value="0.05"/></bsdf>
    <bsdf type="conductor" id="mat_mirror"><string name="material" value="Ag"/></bsdf>
    <bsdf type="dielectric" id="mat_glass"><float name="int_ior" value="1.5"/></bsdf>
    <bsdf type="twosided" id="mat_shade"><bsdf type="diffuse">
        <rgb name="reflectance" value="0.85, 0.8, 0.65"/></bsdf></bsdf>
    <bsdf type="diffuse" id="mat_frame"><rgb name="reflectance" value="0.05, 0.05, 0.05"/></bsdf>
"""


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(os.path.join(out, "meshes"), exist_ok=True)
    textures(out)
    rnd = random.Random(44)
    shapes = []  # (name, mesh, bsdf id, extra xml)

    def add(name, mesh, bsdf):
        shapes.append((name, mesh, bsdf))

    W, H, D, T = 8.0, 3.0, 6.0, 0.1  # room x in [0, 8], y in [0, 3], z in [0, 6]; wall thickness
    add("floor", box((0, -T, 0), (W, 0, D), uv_scale=0.5, n=8), "floor")
    add("ceiling", box((0, H, 0), (W, H + T, D), n=8), "ceiling")
    add("wall_back", box((0, 0, -T), (W, H, 0), uv_scale=1.5, n=4), "wall")
    add("wall_front", box((0, 0, D), (W, H, D + T), uv_scale=1.5, n=4), "wall")
    add("wall_right", box((W, 0, 0), (W + T, H, D), uv_scale=1.5, n=4), "wall")
    # Left wall with a window opening (x = 0, z in [2, 4], y in [0.9, 2.4]).
    add("wall_left_a", box((-T, 0, 0), (0, H, 2), uv_scale=1.5, n=2), "wall")
    add("wall_left_b", box((-T, 0, 4), (0, H, D), uv_scale=1.5, n=2), "wall")
    add("wall_left_sill", box((-T, 0, 2), (0, 0.9, 4), uv_scale=1.5), "wall")
    add("wall_left_lintel", box((-T, 2.4, 2), (0, H, 4), uv_scale=1.5), "wall")
    add("window_mullion", box((-0.08, 0.9, 2.97), (-0.02, 2.4, 3.03)), "frame")
    add("window_transom", box((-0.08, 1.62, 2), (-0.02, 1.68, 4)), "frame")
    add("rug", box((2.5, 0, 1.8), (6.0, 0.01, 4.2), uv_scale=1 / 3.5), "rug")

    # Dining table and six chairs.
    tx, tz = 5.5, 3.0
    add("table_top", box((tx - 1.0, 0.72, tz - 0.5), (tx + 1.0, 0.76, tz + 0.5), n=4), "varnish")
    for i, (dx, dz) in enumerate([(-0.9, -0.4), (0.9, -0.4), (-0.9, 0.4), (0.9, 0.4)]):
        add(f"table_leg{i}", box((tx + dx - 0.03, 0, tz + dz - 0.03), (tx + dx + 0.03, 0.72, tz + dz + 0.03)),
            "varnish")
    for i, (cx, cz, rot) in enumerate([(tx - 0.5, tz - 0.8, 0), (tx + 0.5, tz - 0.8, 0), (tx - 0.5, tz + 0.8, math.pi),
                                       (tx + 0.5, tz + 0.8, math.pi), (tx - 1.35, tz, -math.pi / 2),
                                       (tx + 1.35, tz, math.pi / 2)]):
        rot += rnd.uniform(-0.15, 0.15)
        piv = (cx, cz)
        add(f"chair{i}_seat", box((cx - 0.22, 0.43, cz - 0.22), (cx + 0.22, 0.47, cz + 0.22), rot_y=rot, pivot=piv),
            "darkwood")
        add(f"chair{i}_back", box((cx - 0.22, 0.47, cz - 0.24), (cx + 0.22, 0.95, cz - 0.21), rot_y=rot, pivot=piv),
            "darkwood")
        legs = Mesh()
        for dx, dz in [(-0.19, -0.19), (0.19, -0.19), (-0.19, 0.19), (0.19, 0.19)]:
            merge(legs, box((cx + dx - 0.02, 0, cz + dz - 0.02), (cx + dx + 0.02, 0.43, cz + dz + 0.02),
                            rot_y=rot, pivot=piv))
        add(f"chair{i}_legs", legs, "darkwood")

    # Sofa against the right wall, with cushions.
    sx = W - 0.95
    add("sofa_base", box((sx, 0.1, 1.2), (W - 0.05, 0.45, 4.8), n=6), "fabric")
    add("sofa_back", box((W - 0.3, 0.45, 1.2), (W - 0.05, 1.0, 4.8), n=6), "fabric")
    add("sofa_arm0", box((sx, 0.45, 1.2), (W - 0.05, 0.7, 1.45), n=3), "fabric")
    add("sofa_arm1", box((sx, 0.45, 4.55), (W - 0.05, 0.7, 4.8), n=3), "fabric")
    for i in range(4):
        z = 1.75 + i * 0.85
        prof = [(0.0, 0.0), (0.18, 0.02), (0.22, 0.1), (0.2, 0.18), (0.12, 0.22), (0.0, 0.23)]
        add(f"cushion{i}", lathe(prof, (W - 0.45, 0.5, z), 48, rings=24), "cushion")

    # Shelves on the back wall with books (one mesh per shelf and binding).
    for s in range(4):
        books = {}
        y = 0.3 + s * 0.5
        add(f"shelf{s}", box((0.6, y, 0.02), (3.4, y + 0.03, 0.35)), "varnish")
        x = 0.65
        while True:
            w = rnd.uniform(0.03, 0.07)
            h = rnd.uniform(0.2, 0.42)
            if x + w > 3.35:
                break
            if rnd.random() < 0.08:
                x += rnd.uniform(0.05, 0.2)
                continue
            mat = rnd.choice(["darkwood", "fabric", "cushion", "glaze", "ceramic", "rug"])
            merge(books.setdefault(mat, Mesh()),
                  box((x, y + 0.03, 0.04), (x + w, y + 0.03 + h, 0.04 + rnd.uniform(0.17, 0.27))))
            x += w + 0.004
        for mat, mesh in sorted(books.items()):
            add(f"books{s}_{mat}", mesh, mat)
    for side in (0.57, 3.4):
        add(f"shelf_side{int(side * 10)}", box((side, 0, 0.02), (side + 0.03, 2.1, 0.35)), "varnish")

    # Paintings on the walls.
    for i, (x0, y0, x1, y1) in enumerate([(4.2, 1.2, 5.6, 2.2), (6.0, 1.4, 7.2, 2.3)]):
        add(f"painting{i}_frame", box((x0 - 0.05, y0 - 0.05, 0.0), (x1 + 0.05, y1 + 0.05, 0.02)), "frame")
        m = Mesh()
        m.v = [(x0, y0, 0.025), (x1, y0, 0.025), (x1, y1, 0.025), (x0, y1, 0.025)]
        m.vt = [(0, 1), (1, 1), (1, 0), (0, 0)]
        m.f = [(0, 1, 2), (0, 2, 3)]
        shapes.append((f"painting{i}", m, f"painting{i}"))
    m = Mesh()
    m.v = [(W - 0.02, 1.3, 2.3), (W - 0.02, 1.3, 3.7), (W - 0.02, 2.3, 3.7), (W - 0.02, 2.3, 2.3)]
    m.vt = [(0, 1), (1, 1), (1, 0), (0, 0)]
    m.f = [(0, 1, 2), (0, 2, 3)]
    shapes.append(("painting2", m, "painting2"))

    # Table ware: plates, cups, bowls, vases, a glass jug, candle holders.
    for i in range(6):
        a = i / 6 * 2 * math.pi
        px, pz = tx + 0.65 * math.cos(a), tz + 0.3 * math.sin(a)
        add(f"plate{i}", lathe([(0, 0), (0.09, 0.002), (0.12, 0.012), (0.125, 0.018)], (px, 0.76, pz), 48), "ceramic")
        add(f"cup{i}", lathe([(0, 0), (0.03, 0.0), (0.04, 0.06), (0.042, 0.09), (0.039, 0.09), (0.037, 0.06),
                              (0.0, 0.008)], (px + 0.12, 0.76, pz + 0.08), 48, rings=16), "glaze")
    add("bowl", lathe([(0, 0), (0.08, 0.0), (0.15, 0.05), (0.18, 0.11), (0.17, 0.11), (0.14, 0.055), (0, 0.01)],
                      (tx, 0.76, tz), 64, rings=24), "steel")
    add("jug", lathe([(0, 0), (0.07, 0), (0.08, 0.1), (0.05, 0.22), (0.055, 0.28), (0.05, 0.28), (0.045, 0.22),
                      (0.072, 0.1), (0.0, 0.006)], (tx + 0.3, 0.76, tz - 0.1), 64, rings=32), "glass")
    for i in range(2):
        add(f"candle_holder{i}", lathe([(0, 0), (0.05, 0), (0.05, 0.01), (0.015, 0.03), (0.012, 0.2), (0.025, 0.22),
                                        (0.0, 0.22)], (tx - 0.4 + 0.8 * i, 0.76, tz), 48, rings=24), "brass")
    for i, (vx, vz, h, mat) in enumerate([(0.3, 5.6, 0.6, "glaze"), (7.6, 5.6, 0.8, "ceramic"), (7.6, 0.4, 0.5, "brass"),
                                          (1.2, 0.2, 0.35, "glass")]):
        prof = [(0.0, 0.0), (0.1, 0.0), (0.16, 0.3 * h), (0.12, 0.7 * h), (0.06, 0.9 * h), (0.08, h),
                (0.07, h), (0.05, 0.9 * h), (0.11, 0.7 * h), (0.15, 0.3 * h), (0.0, 0.01)]
        y0 = 0.0 if vx > 1 or vz > 1 else 2.33
        add(f"vase{i}", lathe(prof, (vx, y0, vz), 96, rings=64), mat)
    add("mirror_ball", sphere((6.8, 0.25, 5.2), 0.25), "mirror")
    add("sideboard", box((5.0, 0, 5.5), (7.0, 0.8, 5.95), n=4), "varnish")
    for i in range(3):
        add(f"sideboard_knob{i}", sphere((5.5 + 0.5 * i, 0.6, 5.47), 0.02, 16), "brass")
    add("coffee_table", box((3.3, 0.35, 2.4), (4.7, 0.4, 3.6), n=4), "glaze")
    for i, (dx, dz) in enumerate([(0.05, 0.05), (1.35, 0.05), (0.05, 1.15), (1.35, 1.15)]):
        add(f"coffee_leg{i}", lathe([(0.025, 0), (0.02, 0.35)], (3.3 + dx - 0.0, 0, 2.4 + dz), 24), "steel")
    for i in range(5):
        add(f"ornament{i}", sphere((3.6 + 0.2 * i, 0.45, 3.0 + 0.1 * math.sin(i)), 0.05, 32),
            ["mirror", "brass", "glaze", "glass", "ceramic"][i])

    # Floor lamp: stand, shade, and a bulb inside (an emitter).
    lx, lz = 7.3, 5.2
    add("lamp_base", lathe([(0, 0), (0.18, 0), (0.18, 0.03), (0.02, 0.05), (0.0, 0.05)], (lx, 0, lz), 48), "brass")
    add("lamp_pole", lathe([(0.012, 0), (0.012, 1.45)], (lx, 0.04, lz), 16), "brass")
    add("lamp_shade", lathe([(0.26, 0), (0.15, 0.3)], (lx, 1.35, lz), 64, rings=8), "shade")

    xml = ['<?xml version="1.0" encoding="utf-8"?>',
           "<!-- Generated by bench/make_interior.py (focal's throughput benchmark); do not edit. -->",
           '<scene version="3.0.0">',
           '    <default name="spp" value="32"/>', '    <default name="resx" value="320"/>',
           '    <default name="resy" value="180"/>', '    <default name="max_depth" value="40"/>',
           '    <integrator type="path"><integer name="max_depth" value="$max_depth"/></integrator>',
           '    <sensor type="perspective">', '        <float name="fov" value="70"/>',
           '        <string name="fov_axis" value="x"/>',
           '        <transform name="to_world"><lookat origin="0.6, 1.55, 5.6" target="5.2, 0.9, 2.2" up="0, 1, 0"/></transform>',
           '        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>',
           '        <film type="hdrfilm"><integer name="width" value="$resx"/><integer name="height" value="$resy"/></film>',
           "    </sensor>", MATERIALS]
    for i in range(3):
        xml.append(f'    <bsdf type="diffuse" id="mat_painting{i}"><texture type="bitmap" name="reflectance">'
                   f'<string name="filename" value="textures/painting{i}.png"/></texture></bsdf>')
    tris = 0
    for name, mesh, bsdf in shapes:
        mesh.write(os.path.join(out, "meshes", f"{name}.obj"))
        tris += len(mesh.f)
        xml.append(f'    <shape type="obj" id="{name}"><string name="filename" value="meshes/{name}.obj"/>'
                   f'<ref id="mat_{bsdf}"/></shape>')
    # Lights: two ceiling panels, the lamp's bulb, the sky behind the window.
    for i, x in enumerate((2.5, 5.5)):
        xml.append(f'    <shape type="rectangle" id="ceiling_light{i}"><transform name="to_world">'
                   f'<scale x="0.6" y="0.35" z="1"/><rotate x="1" angle="90"/><translate x="{x}" y="{H - 0.01}" z="3"/>'
                   f'</transform><emitter type="area"><rgb name="radiance" value="14, 13, 11.5"/></emitter></shape>')
    xml.append(f'    <shape type="sphere" id="lamp_bulb"><point name="center" x="{lx}" y="1.5" z="{lz}"/>'
               '<float name="radius" value="0.04"/><emitter type="area"><rgb name="radiance" value="300, 240, 160"/>'
               "</emitter></shape>")
    xml.append('    <emitter type="constant"><rgb name="radiance" value="1.6, 1.8, 2.2"/></emitter>')
    xml.append("</scene>")
    with open(os.path.join(out, "interior.xml"), "w") as f:
        f.write("\n".join(xml) + "\n")
    print(f"{out}/interior.xml: {len(shapes) + 3} shapes ({len(shapes)} meshes, {tris} triangles)")


if __name__ == "__main__":
    main()
