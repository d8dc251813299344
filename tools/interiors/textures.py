"""Procedural bitmap textures for the generated interiors, written as 8-bit sRGB PNGs (standard library only).

Each texture is deterministic (a fixed-seed generator), so regenerating the scenes gives the same bytes.
"""

import math
import random
import struct
import zlib


def write_png(path, width, height, pixels):
    """pixels: a list of rows, each a list of (r, g, b) floats in [0, 1] (already sRGB-encoded)."""
    raw = bytearray()
    for row in pixels:
        raw.append(0)
        for r, g, b in row:
            raw += bytes(max(0, min(255, int(round(c * 255)))) for c in (r, g, b))

    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    with open(path, "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n")
        out.write(chunk(b"IHDR", header))
        out.write(chunk(b"IDAT", zlib.compress(bytes(raw), 9)))
        out.write(chunk(b"IEND", b""))


def mix(a, b, t):
    return tuple(x + (y - x) * t for x, y in zip(a, b))


def wood_planks(size=256, planks=4, seed=1, base=(0.6, 0.47, 0.34), dark=(0.4, 0.3, 0.21)):
    """Floor boards running along u: `planks` boards across the tile, each with its own tone and grain."""
    rng = random.Random(seed)
    tones = [rng.uniform(0.0, 0.45) for _ in range(planks * 2)]
    phases = [rng.uniform(0, 2 * math.pi) for _ in range(planks * 2)]
    rows = []
    for y in range(size):
        plank = y * planks // size
        edge = (y * planks) % size < 2
        row = []
        for x in range(size):
            # boards are split in two along their length, staggered
            half = 0 if (x + plank * size // 3) % size < size // 2 else 1
            k = plank * 2 + half
            grain = 0.5 + 0.5 * math.sin(y * 0.9 + 6 * math.sin(x * 0.023 + phases[k]) + phases[k])
            t = min(1.0, tones[k] + 0.25 * grain)
            c = mix(base, dark, t)
            if edge or (x + plank * size // 3) % (size // 2) == 0:
                c = mix(c, (0.12, 0.08, 0.05), 0.7)
            row.append(c)
        rows.append(row)
    return size, size, rows


def wallpaper(size=128, seed=2, ground=(0.8, 0.79, 0.74), stripe=(0.62, 0.66, 0.7)):
    """Vertical stripes with a small diamond motif: a warm, light wallpaper."""
    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            s = 0.5 + 0.5 * math.cos(2 * math.pi * x / size * 4)
            c = mix(ground, stripe, 0.6 * s ** 6)
            dx = abs((x % (size // 4)) - size // 8)
            dy = abs((y % (size // 4)) - size // 8)
            if dx + dy < 4:
                c = mix(c, stripe, 0.8)
            row.append(c)
        rows.append(row)
    return size, size, rows


def rug(size=128, seed=3):
    """A rug with a border and a lattice, in deep reds and blues."""
    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            u, v = x / size, y / size
            border = min(u, v, 1 - u, 1 - v) < 0.08
            inner = min(u, v, 1 - u, 1 - v) < 0.1
            lattice = (math.sin(u * 2 * math.pi * 6) * math.sin(v * 2 * math.pi * 4)) > 0.6
            if border:
                c = (0.15, 0.18, 0.35)
            elif inner:
                c = (0.75, 0.65, 0.4)
            elif lattice:
                c = (0.8, 0.7, 0.45)
            else:
                c = (0.45, 0.08, 0.08)
            row.append(c)
        rows.append(row)
    return size, size, rows


def painting(width=96, height=64, seed=4):
    """An abstract landscape: sky gradient, hills and a sun."""
    rng = random.Random(seed)
    hills = [(rng.uniform(0, 1), rng.uniform(0.05, 0.2), rng.uniform(0.5, 0.75)) for _ in range(4)]
    rows = []
    for y in range(height):
        row = []
        for x in range(width):
            u, v = x / width, y / height
            c = mix((0.35, 0.55, 0.8), (0.9, 0.75, 0.5), v)
            for cx, w, top in hills:
                if v > top - w * math.exp(-((u - cx) / 0.2) ** 2):
                    c = mix((0.2, 0.4, 0.15), (0.35, 0.5, 0.2), cx)
            if (u - 0.75) ** 2 + (v - 0.25) ** 2 < 0.004:
                c = (0.98, 0.9, 0.6)
            row.append(c)
        rows.append(row)
    return width, height, rows


def plaster(size=128, seed=5, base=(0.72, 0.7, 0.66)):
    """A faintly mottled plaster: low-frequency value noise."""
    rng = random.Random(seed)
    grid = 8
    values = [[rng.uniform(-1, 1) for _ in range(grid + 1)] for _ in range(grid + 1)]
    for row in values:
        row[grid] = row[0]
    values[grid] = values[0]

    def noise(u, v):
        x, y = u * grid, v * grid
        i, j = int(x), int(y)
        fx, fy = x - i, y - j
        fx, fy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
        a = values[j][i] + (values[j][i + 1] - values[j][i]) * fx
        b = values[j + 1][i] + (values[j + 1][i + 1] - values[j + 1][i]) * fx
        return a + (b - a) * fy

    rows = []
    for y in range(size):
        rows.append([tuple(c * (1 + 0.06 * noise(x / size, y / size)) for c in base) for x in range(size)])
    return size, size, rows


def books(width=128, height=32, seed=6):
    """A row of book spines in assorted colours."""
    rng = random.Random(seed)
    palette = [(0.5, 0.1, 0.1), (0.1, 0.25, 0.45), (0.15, 0.35, 0.2), (0.6, 0.5, 0.3), (0.2, 0.2, 0.22),
               (0.7, 0.65, 0.55), (0.45, 0.25, 0.4)]
    spines = []
    x = 0
    while x < width:
        w = rng.randint(3, 7)
        spines.append((x, x + w, rng.choice(palette), rng.uniform(0.7, 1.0)))
        x += w
    rows = []
    for y in range(height):
        row = []
        for x in range(width):
            for x0, x1, c, h in spines:
                if x0 <= x < x1:
                    top = (1 - h) * height
                    row.append((0.08, 0.06, 0.05) if y < top else c)
                    break
        rows.append(row)
    return width, height, rows
