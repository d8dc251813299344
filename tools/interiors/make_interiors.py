#!/usr/bin/env python3
"""Generates focal's interior benchmark scenes (scenes/*.xml, their meshes and textures).

  python3 tools/interiors/make_interiors.py [--out scenes]

Four rooms lit through small openings, each at 320x180 by default (`-D width=... -D height=...`):
  dining_room.xml   pendant lamps over a table: tiny, very bright bulbs inside shades open at the bottom
                    (diffuse, mirror and glossy copper inside);
  stair_hall.xml    a two-storey hall lit only by up-lighting wall sconces whose light leaves through a slot;
  living_room.xml   a table lamp with a diffuse-transmitting shade, and sun and sky through a small window;
  door_ajar.xml     a study with textured walls and glossy furniture, lit through a door left ajar.
Standard library only; the output is deterministic.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import furniture as fu  # noqa: E402
import textures as tx  # noqa: E402
from geometry import Mesh, box, frustum, annulus, wall_with_holes  # noqa: E402
from scene_xml import (SceneXml, area, conductor, difftrans, diffuse, roughconductor,  # noqa: E402
                 roughplastic, twosided)

WARM = (1.0, 0.86, 0.7)


def scaled(rgb, s):
    return tuple(round(c * s, 6) for c in rgb)


class Assets:
    """Writes meshes and textures under OUT/interiors/ and hands back their paths relative to OUT."""

    def __init__(self, out, scene):
        self.out = out
        self.dir = os.path.join(out, "interiors", scene)
        os.makedirs(self.dir, exist_ok=True)
        os.makedirs(os.path.join(out, "interiors", "textures"), exist_ok=True)
        self.scene = scene

    def mesh(self, name, mesh):
        mesh.write(os.path.join(self.dir, name + ".obj"))
        return f"interiors/{self.scene}/{name}.obj"

    def texture(self, name, generator):
        path = os.path.join(self.out, "interiors", "textures", name + ".png")
        if not os.path.exists(path):
            w, h, rows = generator()
            tx.write_png(path, w, h, rows)
        return f"interiors/textures/{name}.png"


def room_shell(a, x0, x1, y1, z0, z1, holes=None):
    """Floor, ceiling and four walls of a box room, facing inwards, as separate meshes (floor, ceiling,
    walls). `holes` maps a wall ('-x', '+x', '-z', '+z') to its openings (u0, v0, u1, v1) in metres
    along the wall (u from the wall's left as seen from inside, v up)."""
    holes = holes or {}
    floor = box((x0, -0.01, z0), (x1, 0.0, z1), skip=("-x", "+x", "-y", "-z", "+z"))
    ceiling = box((x0, y1, z0), (x1, y1 + 0.01, z1), skip=("-x", "+x", "+y", "-z", "+z"))
    walls = Mesh()
    # seen from inside, each wall's u runs left to right
    walls.extend(wall_with_holes((x0, 0, z1), (0, 0, -1), (0, 1, 0), z1 - z0, y1, holes.get("-x", [])))
    walls.extend(wall_with_holes((x1, 0, z0), (0, 0, 1), (0, 1, 0), z1 - z0, y1, holes.get("+x", [])))
    walls.extend(wall_with_holes((x0, 0, z0), (1, 0, 0), (0, 1, 0), x1 - x0, y1, holes.get("-z", [])))
    walls.extend(wall_with_holes((x1, 0, z1), (-1, 0, 0), (0, 1, 0), x1 - x0, y1, holes.get("+z", [])))
    return floor, ceiling, walls


# --------------------------------------------------------------------------------------------------------
def dining_room(out):
    a = Assets(out, "dining_room")
    s = SceneXml("""Dining room lit only by three pendant lamps (focal benchmark interior).
     A 6 x 2.8 x 5 m room (x in [-3, 3], z in [-2.5, 2.5]) with a table, six chairs, a sideboard, a
     rug, a painting and a plant. Three pendants hang 75 cm above the table; each hides a 1 cm bulb of
     radiance 2.25e5 inside a shade open at the bottom: diffuse white inside (left), a smooth aluminium
     mirror inside (middle) and rough copper inside (right). The camera stands above the shades' rims,
     so no bulb is seen directly.
     Intent: all light leaves through the three 44 cm openings. Below each lamp next-event estimation
     finds the bulb, but everywhere else the room is lit by light that passed a shade's inside: from a
     diffuse point, the bright inner wall of the diffuse shade, the bulb's virtual images in the mirror
     shade (focal points NEE cannot connect to) and the copper shade's glossy glare are small targets
     that BSDF sampling rarely hits: a room that renders black or correct depending on the seed.""")
    wood = a.texture("wood_planks", tx.wood_planks)
    paper = a.texture("wallpaper", tx.wallpaper)
    plaster = a.texture("plaster", tx.plaster)
    s.bsdf("floor", diffuse(texture=wood, uv_scale=1.25))
    s.bsdf("wallpaper", diffuse(texture=paper, uv_scale=2.0))
    s.bsdf("ceiling", diffuse(texture=plaster, uv_scale=0.5))
    s.bsdf("table_wood", roughplastic(alpha=0.12, texture=wood, uv_scale=2.5))
    s.bsdf("chair_wood", roughplastic(rgb=(0.22, 0.13, 0.07), alpha=0.2))
    s.bsdf("white_paint", roughplastic(rgb=(0.8, 0.8, 0.78), alpha=0.08))
    s.bsdf("enamel", roughplastic(rgb=(0.05, 0.18, 0.12), alpha=0.15))
    s.bsdf("black", diffuse(rgb=(0.03, 0.03, 0.03)))

    floor, ceiling, walls = room_shell(a, -3, 3, 2.8, -2.5, 2.5)
    s.mesh("floor", a.mesh("floor", floor), "floor")
    s.mesh("ceiling", a.mesh("ceiling", ceiling), "ceiling")
    s.mesh("walls", a.mesh("walls", walls), "wallpaper")
    skirting = Mesh()
    for lo, hi in (((-3, 0, -2.5), (3, 0.1, -2.48)), ((-3, 0, 2.48), (3, 0.1, 2.5)),
                   ((-3, 0, -2.5), (-2.98, 0.1, 2.5)), ((2.98, 0, -2.5), (3, 0.1, 2.5))):
        skirting.extend(box(lo, hi))
    s.mesh("skirting", a.mesh("skirting", skirting), "white_paint")
    door = box((2.94, 0.0, 0.9), (3.0, 2.05, 1.8))
    s.mesh("door", a.mesh("door", door), "chair_wood")

    s.mesh("table", a.mesh("table", fu.table(2.0, 1.0, 0.76)), "table_wood")
    chairs = Mesh()
    for x, z, angle in ((-0.5, -0.75, 180), (0.5, -0.75, 180), (-0.5, 0.75, 0), (0.5, 0.75, 0),
                        (-1.3, 0.0, -90), (1.3, 0.0, 90)):
        chairs.extend(fu.placed(fu.chair(), (x, 0, z), angle))
    s.mesh("chairs", a.mesh("chairs", chairs), "chair_wood")
    s.mesh("sideboard", a.mesh("sideboard", box((-1.0, 0.0, -2.5), (1.0, 0.85, -2.05))), "white_paint")
    s.sphere("vase", (0.55, 1.0, -2.27), 0.15, bsdf=roughplastic(rgb=(0.08, 0.2, 0.45), alpha=0.05))
    frame, canvas = fu.frame_and_canvas((0.0, 1.75, -2.5), 1.2, 0.8, "+z")
    s.mesh("frame", a.mesh("frame", frame), "black")
    s.mesh("painting", a.mesh("painting", canvas), bsdf=diffuse(texture=a.texture("painting", tx.painting)))
    s.mesh("rug", a.mesh("rug", fu.rug(-1.8, -1.3, 1.8, 1.3)), bsdf=diffuse(texture=a.texture("rug", tx.rug)))
    pot, soil, leaves = fu.pot_plant((-2.5, 0.0, -2.0))
    s.mesh("pot", a.mesh("pot", pot), bsdf=roughplastic(rgb=(0.5, 0.22, 0.12), alpha=0.3))
    s.mesh("soil", a.mesh("soil", soil), "black")
    for i, (c, r) in enumerate(leaves):
        s.sphere(f"leaves_{i}", c, r, bsdf=diffuse(rgb=(0.08, 0.22, 0.06)))

    insides = {
        "diffuse": diffuse(rgb=(0.85, 0.85, 0.82)),
        "mirror": conductor("Al"),
        "copper": roughconductor("Cu", 0.08),
    }
    cords = Mesh()
    for name, x in (("diffuse", -0.8), ("mirror", 0.0), ("copper", 0.8)):
        outer, inner = fu.pendant_shade((x, 0.0), 1.5, 1.78, 0.22, 0.09)
        s.mesh(f"shade_{name}_outside", a.mesh(f"shade_{name}_outside", outer), "enamel")
        s.mesh(f"shade_{name}_inside", a.mesh(f"shade_{name}_inside", inner), bsdf=insides[name])
        socket = frustum((x, 0.0), 0.018, 0.018, 1.777, 1.69)
        socket.extend(annulus((x, 0.0), 1.69, 0.0, 0.018, up=False))
        cords.extend(socket)
        cords.extend(fu.cord(x, 0.0, 2.8, 1.78))
        s.sphere(f"bulb_{name}", (x, 1.665, 0.0), 0.01, emitter=area(scaled(WARM, 2.25e5)))
    s.mesh("cords", a.mesh("cords", cords), "black")

    s.look_at((0.9, 1.65, 2.4), (-0.15, 1.0, -0.5), fov=72)
    return s


# --------------------------------------------------------------------------------------------------------
def stair_hall(out):
    a = Assets(out, "stair_hall")
    s = SceneXml("""Stair hall lit only by up-lighting wall sconces (focal benchmark interior).
     A two-storey hall (x in [-2.5, 2.5], y in [0, 5.6], z in [-3, 3]) with a staircase along the left
     wall up to a gallery over the back half, a railing, a bench, a console table, pictures and a plant.
     Four sconces (two on the ground floor, two upstairs) are closed boxes with a 8 x 3 cm slot in the
     top; inside each, 7 cm below the slot, a 1.5 cm bulb of radiance 3e5, and a white interior.
     Intent: every light path leaves a sconce through its slot. The slot throws a bright fan onto the
     wall and ceiling above it, which lights the hall; light that bounced inside a sconce leaves the
     slot in all upward directions and can reach a room point only through that slot (a focal region
     of 24 cm^2).""")
    wood = a.texture("wood_planks", tx.wood_planks)
    plaster = a.texture("plaster", tx.plaster)
    s.bsdf("floor", roughplastic(alpha=0.2, texture=wood, uv_scale=1.25))
    s.bsdf("plaster", diffuse(texture=plaster, uv_scale=0.4))
    s.bsdf("stairs", roughplastic(alpha=0.15, texture=wood, uv_scale=2.0))
    s.bsdf("white_paint", roughplastic(rgb=(0.8, 0.8, 0.78), alpha=0.08))
    s.bsdf("sconce_outside", roughplastic(rgb=(0.75, 0.68, 0.52), alpha=0.1))
    s.bsdf("sconce_inside", diffuse(rgb=(0.85, 0.85, 0.85)))
    s.bsdf("dark_metal", roughplastic(rgb=(0.02, 0.02, 0.02), alpha=0.2))
    s.bsdf("black", diffuse(rgb=(0.03, 0.03, 0.03)))

    floor, ceiling, walls = room_shell(a, -2.5, 2.5, 5.6, -3, 3)
    s.mesh("floor", a.mesh("floor", floor), "floor")
    s.mesh("ceiling", a.mesh("ceiling", ceiling), "plaster")
    s.mesh("walls", a.mesh("walls", walls), "plaster")

    # the gallery slab over z in [-3, -1], its front face and underside
    slab = box((-2.5, 2.8, -3.0), (2.5, 3.0, -1.0), skip=("-x", "+x", "-z", "+y"))
    s.mesh("gallery", a.mesh("gallery", slab), "white_paint")
    gallery_floor = box((-2.5, 3.0, -3.0), (2.5, 3.01, -1.0), skip=("-x", "+x", "-z", "+z", "-y"))
    s.mesh("gallery_floor", a.mesh("gallery_floor", gallery_floor), "floor")
    # steps: 17 risers of 0.176 m from z = 2.0 back to the gallery edge at z = -1.0
    steps = Mesh()
    n = 17
    for i in range(n):
        y = (i + 1) * 3.0 / n
        z_front = 2.0 - i * 3.0 / n
        steps.extend(box((-2.5, 0.0, z_front - 3.0 / n), (-1.5, y, z_front), skip=("-x",)))
    s.mesh("stairs", a.mesh("stairs", steps), "stairs")
    railing = Mesh()
    for i in range(11):
        x = -1.45 + i * 0.39
        railing.extend(box((x - 0.015, 3.0, -1.03), (x + 0.015, 3.95, -1.0)))
    railing.extend(box((-1.5, 3.95, -1.06), (2.5, 4.0, -0.98)))
    for i in range(n):
        y = (i + 1) * 3.0 / n
        z = 2.0 - (i + 0.5) * 3.0 / n
        if i % 2 == 0:
            railing.extend(box((-1.54, y, z - 0.015), (-1.51, y + 0.9, z + 0.015)))
    s.mesh("railing", a.mesh("railing", railing), "dark_metal")
    hand = Mesh()
    for i in range(n):
        y0, y1 = (i + 1) * 3.0 / n + 0.9, (i + 2) * 3.0 / n + 0.9
        z0, z1 = 2.0 - i * 3.0 / n, 2.0 - (i + 1) * 3.0 / n
        hand.extend(box((-1.56, min(y0, y1) - 0.02, z1), (-1.49, max(y0, y1), z0)))
    s.mesh("handrail", a.mesh("handrail", hand), "stairs")

    s.mesh("bench", a.mesh("bench", fu.placed(fu.table(1.2, 0.4, 0.45, top=0.05), (1.95, 0, 0.9), 90)), "stairs")
    s.mesh("console", a.mesh("console", fu.placed(fu.table(1.1, 0.35, 0.8), (0.4, 0, -2.8), 0)), "white_paint")
    s.sphere("bowl", (0.4, 0.88, -2.8), 0.09, bsdf=roughplastic(rgb=(0.6, 0.1, 0.05), alpha=0.05))
    frame, canvas = fu.frame_and_canvas((0.4, 1.6, -3.0), 0.9, 0.6, "+z")
    s.mesh("frame", a.mesh("frame", frame), "black")
    s.mesh("painting", a.mesh("painting", canvas), bsdf=diffuse(texture=a.texture("painting", tx.painting)))
    frame2, canvas2 = fu.frame_and_canvas((0.6, 4.3, -3.0), 1.2, 0.8, "+z")
    s.mesh("frame_upstairs", a.mesh("frame_upstairs", frame2), "black")
    s.mesh("painting_upstairs", a.mesh("painting_upstairs", canvas2),
           bsdf=diffuse(texture=a.texture("painting", tx.painting)))
    pot, soil, leaves = fu.pot_plant((2.0, 0.0, -2.5))
    s.mesh("pot", a.mesh("pot", pot), bsdf=roughplastic(rgb=(0.3, 0.3, 0.32), alpha=0.2))
    s.mesh("soil", a.mesh("soil", soil), "black")
    for i, (c, r) in enumerate(leaves):
        s.sphere(f"leaves_{i}", c, r, bsdf=diffuse(rgb=(0.08, 0.22, 0.06)))

    for i, (point, normal) in enumerate(((( 2.5, 1.9, -1.9), "-x"), ((2.5, 1.9, 1.4), "-x"),
                                         ((-0.9, 4.1, -3.0), "+z"), ((1.6, 4.1, -3.0), "+z"))):
        outer, inner, bulb = fu.uplight_sconce(point, normal)
        s.mesh(f"sconce_{i}_outside", a.mesh(f"sconce_{i}_outside", outer), "sconce_outside")
        s.mesh(f"sconce_{i}_inside", a.mesh(f"sconce_{i}_inside", inner), "sconce_inside")
        s.sphere(f"bulb_{i}", bulb, 0.015, emitter=area(scaled(WARM, 3e5)))

    s.look_at((1.9, 1.5, 2.8), (-0.7, 2.5, -1.2), fov=78)
    return s


# --------------------------------------------------------------------------------------------------------
def living_room(out):
    a = Assets(out, "living_room")
    s = SceneXml("""Living room lit by a table lamp and by sun and sky through a small window (focal
     benchmark interior).
     A 6 x 2.7 x 6 m room (x, z in [-3, 3]) with a sofa, a coffee table, an armchair, a bookshelf, a
     side table, a rug and a plant. The only window is 70 x 60 cm in the left wall (x = -3, 25 cm deep);
     outside are a sky of constant radiance, a sun (directional, irradiance 60) that throws a patch of
     light on the floor, and the ground. A table lamp stands on the side table right of the sofa: a
     2 cm bulb (radiance 6e3) inside a cylindrical shade open at both ends that transmits diffusely.
     Intent: two focal regions of different kinds. Skylight and light from the sunlit ground reach the
     room only through the window; the lamp's light reaches the room through its glowing shade (which
     blocks shadow rays to the bulb) or through the shade's two openings.""")
    wood = a.texture("wood_planks", tx.wood_planks)
    plaster = a.texture("plaster", tx.plaster)
    s.bsdf("floor", roughplastic(alpha=0.25, texture=wood, uv_scale=1.25))
    s.bsdf("plaster", diffuse(texture=plaster, uv_scale=0.5))
    s.bsdf("fabric", diffuse(rgb=(0.25, 0.3, 0.38)))
    s.bsdf("dark_wood", roughplastic(rgb=(0.12, 0.07, 0.04), alpha=0.08))
    s.bsdf("white_paint", roughplastic(rgb=(0.8, 0.8, 0.78), alpha=0.08))
    s.bsdf("black", diffuse(rgb=(0.03, 0.03, 0.03)))

    window = (2.1, 1.2, 2.8, 1.8)  # along the -x wall, u runs from z = 3 towards z = -3
    floor, ceiling, walls = room_shell(a, -3, 3, 2.7, -3, 3, holes={"-x": [window]})
    s.mesh("floor", a.mesh("floor", floor), "floor")
    s.mesh("ceiling", a.mesh("ceiling", ceiling), "plaster")
    s.mesh("walls", a.mesh("walls", walls), "plaster")
    # the window's reveal (25 cm deep wall thickness) and the outer face of the wall around it
    z0, z1 = 3 - window[2], 3 - window[0]
    y0, y1 = window[1], window[3]
    reveal = Mesh()
    reveal.quad((-3.25, y0, z1), (-3.0, y0, z1), (-3.0, y0, z0), (-3.25, y0, z0))  # sill, facing up
    reveal.quad((-3.25, y1, z0), (-3.0, y1, z0), (-3.0, y1, z1), (-3.25, y1, z1))  # head, facing down
    reveal.quad((-3.25, y0, z0), (-3.0, y0, z0), (-3.0, y1, z0), (-3.25, y1, z0))  # side, facing +z
    reveal.quad((-3.0, y0, z1), (-3.25, y0, z1), (-3.25, y1, z1), (-3.0, y1, z1))  # side, facing -z
    s.mesh("window_reveal", a.mesh("window_reveal", reveal), "white_paint")
    outside = wall_with_holes((-3.25, -0.01, -3.3), (0, 0, 1), (0, 1, 0), 6.6, 3.05,
                              [(z0 + 3.3, y0 + 0.01, z1 + 3.3, y1 + 0.01)])
    s.mesh("outer_wall", a.mesh("outer_wall", outside), bsdf=diffuse(rgb=(0.6, 0.55, 0.5)))
    ground = Mesh()
    ground.quad((-40, -0.02, 40), (-3.26, -0.02, 40), (-3.26, -0.02, -40), (-40, -0.02, -40))
    s.mesh("ground", a.mesh("ground", ground), bsdf=diffuse(rgb=(0.2, 0.25, 0.12)))

    s.mesh("sofa", a.mesh("sofa", fu.placed(fu.sofa(), (0.2, 0, -3.0), 0)), "fabric")
    s.mesh("armchair", a.mesh("armchair", fu.placed(fu.sofa(width=0.9), (-2.2, 0, 1.4), 120)), "fabric")
    s.mesh("coffee_table", a.mesh("coffee_table", fu.placed(fu.table(1.1, 0.6, 0.42), (0.2, 0, -1.3))), "dark_wood")
    s.mesh("side_table", a.mesh("side_table", box((1.45, 0.0, -2.95), (1.95, 0.55, -2.45))), "dark_wood")
    shelf, books = fu.bookshelf()
    s.mesh("bookshelf", a.mesh("bookshelf", fu.placed(shelf, (-1.6, 0, -3.0))), "white_paint")
    s.mesh("books", a.mesh("books", fu.placed(books, (-1.6, 0, -3.0))),
           bsdf=diffuse(texture=a.texture("books", tx.books)))
    s.mesh("rug", a.mesh("rug", fu.rug(-1.2, -2.2, 1.6, -0.2)), bsdf=diffuse(texture=a.texture("rug", tx.rug)))
    frame, canvas = fu.frame_and_canvas((0.2, 1.65, -3.0), 1.0, 0.65, "+z")
    s.mesh("frame", a.mesh("frame", frame), "black")
    s.mesh("painting", a.mesh("painting", canvas), bsdf=diffuse(texture=a.texture("painting", tx.painting)))
    pot, soil, leaves = fu.pot_plant((2.5, 0.0, -2.5))
    s.mesh("pot", a.mesh("pot", pot), bsdf=roughplastic(rgb=(0.7, 0.68, 0.62), alpha=0.1))
    s.mesh("soil", a.mesh("soil", soil), "black")
    for i, (c, r) in enumerate(leaves):
        s.sphere(f"leaves_{i}", c, r, bsdf=diffuse(rgb=(0.08, 0.22, 0.06)))

    lamp_x, lamp_z = 1.7, -2.7
    base = frustum((lamp_x, lamp_z), 0.03, 0.08, 0.75, 0.55)
    base.extend(frustum((lamp_x, lamp_z), 0.012, 0.012, 1.0, 0.75))
    s.mesh("lamp_base", a.mesh("lamp_base", base), bsdf=roughconductor("Au", 0.15))
    shade = frustum((lamp_x, lamp_z), 0.13, 0.19, 1.2, 0.92, outward=True)
    s.mesh("lamp_shade", a.mesh("lamp_shade", shade), bsdf=difftrans((0.72, 0.62, 0.45)))
    s.sphere("lamp_bulb", (lamp_x, 1.05, lamp_z), 0.02, emitter=area(scaled(WARM, 6e3)))

    s.add('<emitter type="constant">\n    <rgb name="radiance" value="0.9, 1.05, 1.3"/>\n</emitter>')
    s.add('<emitter type="directional">\n    <vector name="direction" value="0.85, -0.45, 0.28"/>\n'
          '    <rgb name="irradiance" value="60, 55, 48"/>\n</emitter>')
    s.look_at((2.5, 1.55, 2.6), (-1.2, 0.95, -1.2), fov=80)
    return s


# --------------------------------------------------------------------------------------------------------
def door_ajar(out):
    a = Assets(out, "door_ajar")
    s = SceneXml("""Study lit through a door left ajar (focal benchmark interior).
     The study (x in [-3.5, 0], z in [-2, 2], 2.6 m high) has papered walls, a wooden floor and glossy
     furniture: a varnished desk and chair, a bookshelf, an aluminium filing cabinet, a chrome
     desk lamp (switched off), a glazed vase and a rug. It is dark but for the light of the corridor
     behind the wall x = 0 (a 60 x 120 cm ceiling panel of radiance 500), which enters through the
     door, opened 10 degrees into the study: a wedge about 16 cm wide at the door's free edge.
     Intent: a realistic door gap. Every path that lights the study passes the wedge; the glossy
     surfaces reflect the bright stripe on the floor and the lit door edge, so their highlights are
     caustics of a focal region that neither NEE nor BSDF sampling finds often.""")
    wood = a.texture("wood_planks", tx.wood_planks)
    paper = a.texture("wallpaper", tx.wallpaper)
    plaster = a.texture("plaster", tx.plaster)
    s.bsdf("floor", roughplastic(alpha=0.2, texture=wood, uv_scale=1.25))
    s.bsdf("wallpaper", diffuse(texture=paper, uv_scale=2.0))
    s.bsdf("plaster", diffuse(texture=plaster, uv_scale=0.5))
    s.bsdf("desk_wood", roughplastic(alpha=0.06, texture=wood, uv_scale=3.0))
    s.bsdf("white_paint", twosided(roughplastic(rgb=(0.8, 0.8, 0.78), alpha=0.08)))
    s.bsdf("aluminium", roughconductor("Al", 0.25))
    s.bsdf("chrome", roughconductor("Cr", 0.04))
    s.bsdf("black", diffuse(rgb=(0.03, 0.03, 0.03)))

    door_z0, door_z1, door_h = 0.5, 1.4, 2.05
    # the study's walls: the wall x = 0 has the door opening, z in [0.5, 1.4] (u from z = -2)
    floor, ceiling, walls = room_shell(a, -3.5, 0.0, 2.6, -2.0, 2.0,
                                       holes={"+x": [(door_z0 + 2.0, 0.0, door_z1 + 2.0, door_h)]})
    s.mesh("floor", a.mesh("floor", floor), "floor")
    s.mesh("ceiling", a.mesh("ceiling", ceiling), "plaster")
    s.mesh("walls", a.mesh("walls", walls), "wallpaper")
    # the corridor beyond: x in [0.12, 2.6], with the same opening on its side of the 12 cm wall
    c_floor, c_ceiling, c_walls = room_shell(a, 0.12, 2.6, 2.6, -2.0, 2.0,
                                             holes={"-x": [(2.0 - door_z1, 0.0, 2.0 - door_z0, door_h)]})
    corridor = Mesh().extend(c_floor).extend(c_ceiling).extend(c_walls)
    s.mesh("corridor", a.mesh("corridor", corridor), bsdf=diffuse(rgb=(0.75, 0.73, 0.7)))
    jamb = Mesh()
    jamb.quad((0.0, 0.0, door_z0), (0.12, 0.0, door_z0), (0.12, door_h, door_z0), (0.0, door_h, door_z0))
    jamb.quad((0.12, 0.0, door_z1), (0.0, 0.0, door_z1), (0.0, door_h, door_z1), (0.12, door_h, door_z1))
    jamb.quad((0.0, door_h, door_z0), (0.12, door_h, door_z0), (0.12, door_h, door_z1), (0.0, door_h, door_z1))
    jamb.quad((0.0, 0.0, door_z1), (0.12, 0.0, door_z1), (0.12, 0.0, door_z0), (0.0, 0.0, door_z0))
    s.mesh("jamb", a.mesh("jamb", jamb), "white_paint")
    ceiling_light = Mesh()
    ceiling_light.quad((1.1, 2.59, -0.6), (1.7, 2.59, -0.6), (1.7, 2.59, 0.6), (1.1, 2.59, 0.6))
    s.mesh("corridor_light", a.mesh("corridor_light", ceiling_light), bsdf=diffuse(rgb=(0.8, 0.8, 0.8)),
           emitter=area((500.0, 475.0, 425.0)))
    # the door: 4 cm thick, hinged at z = 1.4 on the study side, opened 10 degrees into the study
    door = box((-0.04, 0.0, door_z0 + 0.005), (0.0, door_h - 0.005, door_z1))
    hinge = (0.0, 0.0, door_z1)
    door = door.transformed(lambda p: fu.rot_y(p, 10.0, hinge))
    s.mesh("door", a.mesh("door", door), "white_paint")

    s.mesh("desk", a.mesh("desk", fu.placed(fu.table(1.4, 0.7, 0.75), (-2.0, 0, -1.6))), "desk_wood")
    s.mesh("chair", a.mesh("chair", fu.placed(fu.chair(), (-2.0, 0, -1.0), 0)), "desk_wood")
    shelf, books = fu.bookshelf(width=1.2, height=2.0)
    s.mesh("bookshelf", a.mesh("bookshelf", fu.placed(shelf, (-3.5, 0, 0.3), 90)), "white_paint")
    s.mesh("books", a.mesh("books", fu.placed(books, (-3.5, 0, 0.3), 90)),
           bsdf=diffuse(texture=a.texture("books", tx.books)))
    s.mesh("cabinet", a.mesh("cabinet", box((-1.25, 0.0, 1.45), (-0.65, 1.3, 2.0))), "aluminium")
    lamp = frustum((-1.55, -1.75), 0.01, 0.01, 1.15, 0.76)
    lamp.extend(frustum((-1.55, -1.75), 0.02, 0.09, 1.22, 1.1))
    lamp.extend(annulus((-1.55, -1.75), 0.765, 0.0, 0.08, up=True))
    s.mesh("desk_lamp", a.mesh("desk_lamp", lamp), "chrome")
    s.sphere("vase", (-2.45, 0.87, -1.75), 0.11, bsdf=roughplastic(rgb=(0.55, 0.08, 0.06), alpha=0.03))
    s.mesh("rug", a.mesh("rug", fu.rug(-2.8, -0.6, -0.8, 1.4)), bsdf=diffuse(texture=a.texture("rug", tx.rug)))
    frame, canvas = fu.frame_and_canvas((-1.9, 1.7, 2.0), 0.9, 0.6, "-z")
    s.mesh("frame", a.mesh("frame", frame), "black")
    s.mesh("painting", a.mesh("painting", canvas), bsdf=diffuse(texture=a.texture("painting", tx.painting)))

    s.look_at((-3.4, 1.6, -1.9), (0.0, 0.85, 0.75), fov=76)
    return s


SCENES = {
    "dining_room": dining_room,
    "stair_hall": stair_hall,
    "living_room": living_room,
    "door_ajar": door_ajar,
}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "..", "scenes"))
    p.add_argument("--only", help="comma-separated scene names")
    args = p.parse_args()
    names = args.only.split(",") if args.only else list(SCENES)
    for name in names:
        scene = SCENES[name](args.out)
        scene.write(os.path.join(args.out, name + ".xml"))
        print(os.path.join(args.out, name + ".xml"))


if __name__ == "__main__":
    main()
