"""Furniture and fittings for the generated interiors, as Meshes (see geometry.py)."""

from geometry import Mesh, annulus, box, frustum, rot_y, tube, wall_with_holes


def placed(mesh, at, angle=0.0):
    """`mesh` built around the origin, turned by `angle` degrees about the vertical and moved to `at`."""
    return mesh.transformed(lambda p: tuple(a + b for a, b in zip(rot_y(p, angle), at)))


def table(length, depth, height, top=0.04, leg=0.06, inset=0.08, uv_scale=1.0):
    """A table centred on the origin: top and four legs (one mesh)."""
    m = box((-length / 2, height - top, -depth / 2), (length / 2, height, depth / 2), uv_scale)
    for sx in (-1, 1):
        for sz in (-1, 1):
            x = sx * (length / 2 - inset)
            z = sz * (depth / 2 - inset)
            m.extend(box((x - leg / 2, 0, z - leg / 2), (x + leg / 2, height - top, z + leg / 2), uv_scale))
    return m


def chair(seat=0.44, seat_height=0.45, back_height=0.95, leg=0.04):
    """A chair facing -z (its back at +z), centred on the origin."""
    h = seat / 2
    m = box((-h, seat_height - 0.04, -h), (h, seat_height, h))
    for sx in (-1, 1):
        for sz in (-1, 1):
            x, z = sx * (h - leg), sz * (h - leg)
            top = back_height if sz > 0 else seat_height - 0.04
            m.extend(box((x - leg / 2, 0, z - leg / 2), (x + leg / 2, top, z + leg / 2)))
    m.extend(box((-h + leg / 2, seat_height + 0.2, h - leg - 0.015), (h - leg / 2, back_height - 0.03, h - leg + 0.015)))
    return m


def pendant_shade(center, y_bottom, y_top, r_bottom, r_top, thickness=0.003):
    """A pendant lamp shade open at the bottom: (outer side with its top cap and bottom rim, inner side
    with the underside of its cap). The two get different BSDFs."""
    outer = frustum(center, r_top, r_bottom, y_top, y_bottom, outward=True)
    outer.extend(annulus(center, y_top, 0.0, r_top, up=True))
    outer.extend(annulus(center, y_bottom, r_bottom - thickness, r_bottom, up=False))
    inner = frustum(center, r_top - thickness, r_bottom - thickness, y_top - thickness, y_bottom, outward=False)
    inner.extend(annulus(center, y_top - thickness, 0.0, r_top - thickness, up=False))
    return outer, inner


def uplight_sconce(wall_point, normal, width=0.24, height=0.3, depth=0.12, slot=(0.08, 0.03), t=0.004):
    """A wall sconce: a box on the wall, closed but for a slot in its top. `wall_point` is the middle of
    the box's bottom edge on the wall; `normal` is the wall's inward normal ('+x', '-x', '+z' or '-z').
    Returns (outer, inner, bulb centre): the outside, the inside (facing inwards) and where the bulb sits,
    7 cm below the slot."""
    # Build for a wall at z = 0 facing +z, then turn.
    angle = {"+z": 0.0, "-z": 180.0, "+x": 90.0, "-x": -90.0}[normal]
    w, h, d = width / 2, height, depth
    outer = box((-w, 0, 0), (w, h, d), skip=("-z", "+y"))
    inner = box((-w + t, t, t), (w - t, h - t, d - t), inward=True, skip=("+y",))
    sw, sd = slot[0] / 2, slot[1] / 2
    # the top plate with its slot, as seen from above (outer) and from below (inner)
    hole = (w - sw, d / 2 - sd, w + sw, d / 2 + sd)
    outer.extend(wall_with_holes((-w, h, d), (1, 0, 0), (0, 0, -1), 2 * w, d, [(hole[0], d - hole[3], hole[2], d - hole[1])]))
    inner.extend(wall_with_holes((-w, h - t, 0), (1, 0, 0), (0, 0, 1), 2 * w, d, [hole]))
    # the slot's walls through the plate thickness would be t = 4 mm: left open (they barely show)
    bulb = (0.0, h - 0.07, d / 2)
    at = wall_point
    outer = placed(outer, at, angle)
    inner = placed(inner, at, angle)
    bulb = tuple(a + b for a, b in zip(rot_y(bulb, angle), at))
    return outer, inner, bulb


def bookshelf(width=1.0, height=1.8, depth=0.3, shelves=5, t=0.025):
    """A bookshelf facing +z, centred on x = 0, its back at z = 0: (carcass, book rows as front quads)."""
    w = width / 2
    m = box((-w, 0, 0), (-w + t, height, depth))
    m.extend(box((w - t, 0, 0), (w, height, depth)))
    m.extend(box((-w, 0, 0), (w, height, t)))
    books = Mesh()
    for i in range(shelves + 1):
        y = i * (height - t) / shelves
        m.extend(box((-w + t, y, t), (w - t, y + t, depth)))
        if i < shelves:
            y0 = y + t
            # the book spines: a quad 22 cm tall, 5 cm behind the shelf's front
            books.quad((-w + t, y0, depth - 0.05), (w - t, y0, depth - 0.05),
                       (w - t, y0 + 0.22, depth - 0.05), (-w + t, y0 + 0.22, depth - 0.05))
            # and their tops, so the shelf does not look hollow from above
            books.quad((-w + t, y0 + 0.22, depth - 0.05), (w - t, y0 + 0.22, depth - 0.05),
                       (w - t, y0 + 0.22, t), (-w + t, y0 + 0.22, t))
    # uvs: each spine quad spans the whole books texture
    for k in range(0, len(books.vt), 4):
        books.vt[k:k + 4] = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return m, books


def sofa(width=2.0, depth=0.9, seat=0.42, back=0.85, arm=0.62):
    """A sofa facing +z, its back at z = 0, centred on x = 0."""
    w = width / 2
    m = box((-w, 0.08, 0), (w, seat, depth))
    m.extend(box((-w, 0.08, 0), (w, back, 0.22)))
    m.extend(box((-w, 0.08, 0), (-w + 0.18, arm, depth)))
    m.extend(box((w - 0.18, 0.08, 0), (w, arm, depth)))
    for sx in (-1, 1):
        for sz in (0.05, depth - 0.05):
            m.extend(box((sx * (w - 0.08) - 0.03, 0, sz - 0.03), (sx * (w - 0.08) + 0.03, 0.08, sz + 0.03)))
    return m


def pot_plant(at, pot_radius=0.18, pot_height=0.4):
    """A pot (frustum with a soil disk) and a few leaf balls: (pot mesh, soil mesh, leaf spheres)."""
    x, y, z = at
    pot = frustum((x, z), pot_radius, pot_radius * 0.75, y + pot_height, y, outward=True)
    soil = annulus((x, z), y + pot_height - 0.03, 0.0, pot_radius - 0.01, up=True)
    leaves = [((x + dx, y + pot_height + dy, z + dz), r) for dx, dy, dz, r in
              ((0.0, 0.35, 0.0, 0.22), (0.12, 0.55, 0.05, 0.16), (-0.1, 0.6, -0.06, 0.15),
               (0.02, 0.78, 0.08, 0.12), (-0.05, 0.25, 0.12, 0.14))]
    return pot, soil, leaves


def frame_and_canvas(center, width, height, normal="+z", border=0.04, depth=0.03):
    """A picture on a wall: a frame (box) and the canvas quad in front of it, uv spanning [0,1]²."""
    angle = {"+z": 0.0, "-z": 180.0, "+x": 90.0, "-x": -90.0}[normal]
    w, h = width / 2, height / 2
    frame = box((-w - border, -h - border, 0), (w + border, h + border, depth))
    canvas = Mesh()
    canvas.quad((-w, -h, depth + 0.002), (w, -h, depth + 0.002), (w, h, depth + 0.002), (-w, h, depth + 0.002))
    canvas.vt[-4:] = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
    return placed(frame, center, angle), placed(canvas, center, angle)


def rug(x0, z0, x1, z1, y=0.004):
    m = Mesh()
    m.quad((x0, y, z1), (x1, y, z1), (x1, y, z0), (x0, y, z0))
    m.vt[-4:] = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return m


def cord(x, z, y_top, y_bottom, radius=0.004):
    return tube((x, y_bottom, z), (x, y_top, z), radius, segments=8)
