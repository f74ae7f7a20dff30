"""The held-out set: six scenes of the kinds of light SSGI is known to lose on, that no training room resembles
and that no one tunes on (``scenes.HELD_OUT``: score them only before a change is resolved). Built by script
(deterministic: no randomness) from scenes/artist.py's building blocks and saved as .blend files with the
artist set's settings (one camera at frame 1, EEVEE with ray tracing + fast GI at 16 samples, view "Standard").

    .venv/bin/python -m scenes.heldout --out DIR [--size 320x180] [--names kitchen neon_room ...]
    .venv/bin/python -m scenes.heldout --look DIR [--size 320x180] [--sheet docs/heldout_scenes.png]

Scenes (``NAMES``): kitchen, neon_room, product_shot, furnished_room, staircase, bathroom; docs/heldout_scenes.md
says what each holds, why it is there and what it looks like. API as scenes/artist.py's: ``build_<name>(scene)``
fills an emptied scene, ``build(name, size)`` resets Blender to an empty file, builds and returns the scene,
``save(scene, path)`` writes atomically.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import bpy  # noqa: E402

import scenes  # noqa: E402  (the checkout as package ssgi)
from scenes import artist as art  # noqa: E402
from scenes.artist import box, camera, cylinder, diffuse, light, plane, principled, sphere  # noqa: E402
import bmesh  # noqa: E402  (after bpy: bpy makes it importable)
from mathutils import Matrix, Vector  # noqa: E402

NAMES = scenes.HELD_OUT
DEFAULT_SIZE = art.DEFAULT_SIZE
save = art.save

# ------------------------------------------------------------------------------------------ building blocks


def _node(mat, kind):
    return next(n for n in mat.node_tree.nodes if n.bl_idname == kind)


def textured(name, base, texture, scale, plane_axes="xy", colour2=None, roughness=0.5, **inputs):
    """``principled(name, base, texture=texture)`` at ``scale`` (cells per metre), the texture's 2D pattern laid
    on the ``plane_axes`` plane of object space ("xy": floors, "xz": walls facing y, "yz": walls facing x);
    ``colour2`` replaces the darker second colour, ``inputs`` set the texture's other inputs (e.g. Mortar)."""
    m = principled(name, base, roughness=roughness, texture=texture)
    nt, tx = m.node_tree, _node(m, texture)
    tx.inputs["Scale"].default_value = scale
    if colour2 is not None:
        tx.inputs["Color2"].default_value = (*colour2, 1.0)
    for k, v in inputs.items():
        tx.inputs[k].default_value = v
    if plane_axes != "xy":  # the Mapping node turns the wall's plane onto the texture's x and y
        mp = nt.nodes.new("ShaderNodeMapping")
        mp.inputs["Rotation"].default_value = {"xz": (math.pi / 2, 0, 0), "yz": (math.pi / 2, math.pi / 2, 0)}[plane_axes]
        nt.links.new(_node(m, "ShaderNodeTexCoord").outputs["Object"], mp.inputs["Vector"])
        nt.links.new(mp.outputs["Vector"], tx.inputs["Vector"])
    return m


def stripes(name, colour1, colour2, scale, roughness=0.8):
    """Two-colour stripes along x (a Wave texture's bands through a constant colour ramp) on Base Color."""
    m = principled(name, colour1, roughness=roughness, specular=0.3, texture="ShaderNodeTexWave")
    nt, wave = m.node_tree, _node(m, "ShaderNodeTexWave")
    wave.inputs["Scale"].default_value = scale
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "CONSTANT"
    els = ramp.color_ramp.elements
    els[0].color, els[1].position, els[1].color = (*colour1, 1.0), 0.5, (*colour2, 1.0)
    nt.links.new(wave.outputs["Fac"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], _node(m, "ShaderNodeBsdfPrincipled").inputs["Base Color"])
    return m


def emitter(name, colour, strength, pattern=None, scale=4.0):
    """An emissive material on a black base; ``pattern`` (a texture node type) multiplies the emission colour
    by its pattern in object space (a screen's picture)."""
    m = principled(name, (0.0, 0.0, 0.0), roughness=0.4, specular=0.2, emission=colour, strength=strength)
    if pattern:
        nt = m.node_tree
        tc, tx, mix = nt.nodes.new("ShaderNodeTexCoord"), nt.nodes.new(pattern), nt.nodes.new("ShaderNodeMix")
        mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
        tx.inputs["Scale"].default_value = scale
        mix.inputs["Factor"].default_value = 1.0
        mix.inputs["A"].default_value = (*colour, 1.0)
        nt.links.new(tc.outputs["Object"], tx.inputs["Vector"])
        nt.links.new(tx.outputs["Color"], mix.inputs["B"])
        nt.links.new(mix.outputs["Result"], _node(m, "ShaderNodeBsdfPrincipled").inputs["Emission Color"])
    return m


def sun_through(scene, name, energy, elevation_deg, azimuth_deg, angle_deg=1.0):
    """A Sun light whose light travels at ``elevation_deg`` below the horizon towards compass ``azimuth_deg``
    (0: +y, 90: +x)."""
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    travel = Vector((math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), -math.sin(el)))
    sun = light(scene, name, "SUN", (0, 0, 10), energy, angle_deg=angle_deg, colour=(1.0, 0.95, 0.88))
    sun.rotation_euler = travel.to_track_quat("-Z", "Y").to_euler()
    return sun


def _mesh(scene, name, bm, mat, loc=(0, 0, 0), smooth=True):
    return art._object(scene, name, bm, mat, loc, smooth=smooth)


def torus_knot(scene, name, mat, loc, p=2, q=3, radius=0.3, ring=0.13, tube=0.05, steps=192, sides=12):
    """A (p, q) torus knot as a tube of ``tube`` radius (``steps`` x ``sides`` quads): the curve winds p times
    round the axis and q times through a torus of ``radius`` and ``ring``; each cross-section lies on the
    torus' normal (closed without a twist)."""
    bm = bmesh.new()
    rings = []
    for i in range(steps):
        t = 2 * math.pi * i / steps

        def at(t):
            r = radius + ring * math.cos(q * t)
            return Vector((r * math.cos(p * t), r * math.sin(p * t), ring * math.sin(q * t)))
        c, tangent = at(t), (at(t + 1e-4) - at(t - 1e-4)).normalized()
        n = Vector((math.cos(q * t) * math.cos(p * t), math.cos(q * t) * math.sin(p * t), math.sin(q * t)))
        n = (n - n.dot(tangent) * tangent).normalized()
        b = tangent.cross(n)
        rings.append([bm.verts.new(c + tube * (math.cos(a) * n + math.sin(a) * b))
                      for a in (2 * math.pi * k / sides for k in range(sides))])
    for i in range(steps):
        r0, r1 = rings[i], rings[(i + 1) % steps]
        for k in range(sides):
            bm.faces.new((r0[k], r0[(k + 1) % sides], r1[(k + 1) % sides], r1[k]))
    bm.normal_update()
    return _mesh(scene, name, bm, mat, loc)


def suzanne(scene, name, mat, loc, size, rot_z=0.0):
    """Blender's monkey head (bmesh's create_monkey: 500 faces, about 2.7 x 2 units; smooth) scaled by ``size``,
    turned by ``rot_z`` about z (it faces -y before the turn)."""
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm, matrix=Matrix.Rotation(rot_z, 4, "Z") @ Matrix.Scale(size, 4))
    return _mesh(scene, name, bm, mat, loc)


def rippled_cloth(scene, name, mat, center, size, amplitude=0.012, waves=5, cells=40):
    """A cloth lying flat: a ``size`` (sx, sy) grid of ``cells`` x ``cells`` faces rippled in z by a sine of
    ``amplitude`` (``waves`` ripples along y)."""
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=cells, y_segments=cells, size=0.5)
    for v in bm.verts:
        x, y = v.co.x * size[0], v.co.y * size[1]
        v.co = (x, y, amplitude * (1.0 + math.sin(2 * math.pi * waves * (v.co.y + 0.5) + 1.3 * v.co.x)))
    return _mesh(scene, name, bm, mat, center)


def table(scene, name, center, top, height, mat, leg=0.05):
    """A table: a 4 cm top of ``top`` (sx, sy) at ``height`` on four square legs."""
    x, y, _ = center
    box(scene, f"{name}_top", (x, y, height - 0.02), (top[0], top[1], 0.04), mat)
    for i, (sx, sy) in enumerate(((-1, -1), (1, -1), (-1, 1), (1, 1))):
        box(scene, f"{name}_leg{i}", (x + sx * (top[0] / 2 - leg), y + sy * (top[1] / 2 - leg), (height - 0.04) / 2),
            (leg, leg, height - 0.04), mat)


# ------------------------------------------------------------------------------------------ the six scenes


def build_kitchen(scene) -> None:
    """4 x 3.5 x 2.6 m kitchen closed but for a 1.4 x 1.1 m window over the counter; lit only by a Sun light and
    Blender's Sky Texture through it. A brick left wall (Brick Texture), a checker floor, a glossy dark counter
    top (roughness 0.05) on white cabinets, a steel pot (metallic 1, roughness 0.3), a fridge and a small table."""
    w, d, h, t = 4.0, 3.5, 2.6, 0.15
    paint = principled("kitchen_paint", (0.82, 0.8, 0.74))
    brick = textured("brick_wall", (0.55, 0.25, 0.16), "ShaderNodeTexBrick", 2.2, plane_axes="yz",
                     colour2=(0.45, 0.2, 0.13), roughness=0.85, Mortar=(0.7, 0.68, 0.62, 1.0))
    floor = textured("checker_floor", (0.75, 0.75, 0.72), "ShaderNodeTexChecker", 2.5, colour2=(0.12, 0.12, 0.13),
                     roughness=0.35)
    art._room_shell(scene, (floor, principled("kitchen_ceiling", (0.85, 0.85, 0.85)), paint), w, d, h, t,
                    skip=("wall_back", "wall_left"))
    box(scene, "wall_left", (-w / 2 - t / 2, 0, h / 2), (t, d, h), brick)
    art.box_with_hole(scene, "wall_back", (0, d / 2 + t / 2, h / 2), (w + 2 * t, t, h), paint, (-1.1, 0.3, 1.05, 2.15))
    white = principled("cabinet_white", (0.85, 0.85, 0.83), roughness=0.4)
    box(scene, "cabinets", (-0.55, d / 2 - 0.3, 0.43), (2.9, 0.6, 0.86), white)
    box(scene, "counter_top", (-0.55, d / 2 - 0.31, 0.88), (2.94, 0.64, 0.04),
        principled("counter_granite", (0.08, 0.08, 0.09), roughness=0.05))
    cylinder(scene, "pot", (-0.85, d / 2 - 0.35, 0.98), 0.14, 0.14, 0.16,
             principled("steel", (0.75, 0.75, 0.77), roughness=0.3, metallic=1.0))
    cylinder(scene, "pot_lid_knob", (-0.85, d / 2 - 0.35, 1.075), 0.02, 0.02, 0.03,
             principled("knob_black", (0.03, 0.03, 0.03), roughness=0.4), segments=12)
    box(scene, "fridge", (w / 2 - 0.38, d / 2 - 0.36, 0.95), (0.7, 0.68, 1.9),
        principled("fridge_white", (0.88, 0.88, 0.88), roughness=0.2))
    table(scene, "table", (-0.6, -0.4, 0), (1.0, 0.7), 0.75, principled("table_wood", (0.45, 0.28, 0.15), roughness=0.5))
    cylinder(scene, "bowl", (-0.5, -0.35, 0.79), 0.06, 0.11, 0.08, principled("bowl_red", (0.6, 0.08, 0.06), roughness=0.3))
    sun_through(scene, "sun", 9.0, 38.0, 200.0)
    art.world_sky(scene, 38.0, 20.0, strength=0.2)
    camera(scene, (1.55, -1.55, 1.6), (-0.7, 1.0, 0.85), lens=18.0)


def build_neon_room(scene) -> None:
    """A dark 4.5 x 4 x 2.6 m room lit only by emissive meshes (no lamp objects, a black world): a magenta strip
    under the ceiling along the left wall, a cyan tube standing in the back right corner, an orange strip hidden
    behind the sofa, a TV (an emissive panel with a Magic-texture picture) and an emissive orb lamp; a glossy
    dark floor (roughness 0.15), a sofa and a low table."""
    w, d, h = 4.5, 4.0, 2.6
    art._room_shell(scene, (principled("floor_glossy_dark", (0.06, 0.06, 0.07), roughness=0.15),
                            diffuse("ceiling_grey", (0.35, 0.35, 0.35)), diffuse("wall_grey", (0.4, 0.4, 0.42))),
                    w, d, h)
    box(scene, "strip_magenta", (-w / 2 + 0.03, 0.0, h - 0.08), (0.04, d - 0.4, 0.04), emitter("neon_magenta", (1.0, 0.1, 0.7), 14.0))
    cylinder(scene, "tube_cyan", (w / 2 - 0.08, d / 2 - 0.08, h / 2), 0.025, 0.025, h - 0.2,
             emitter("neon_cyan", (0.1, 0.85, 1.0), 14.0), segments=12)
    box(scene, "strip_orange", (-0.4, d / 2 - 0.05, 0.08), (2.2, 0.04, 0.04), emitter("neon_orange", (1.0, 0.45, 0.05), 30.0))
    fabric = principled("sofa_fabric", (0.3, 0.3, 0.34), roughness=0.9)
    box(scene, "sofa_seat", (-0.4, d / 2 - 0.6, 0.22), (2.0, 0.8, 0.44), fabric)
    box(scene, "sofa_back", (-0.4, d / 2 - 0.3, 0.55), (2.0, 0.2, 0.9), fabric)
    box(scene, "low_table", (-0.3, 0.3, 0.2), (1.0, 0.6, 0.4), principled("table_black_gloss", (0.03, 0.03, 0.03), roughness=0.1))
    box(scene, "tv_stand", (w / 2 - 0.25, -0.2, 0.25), (0.4, 1.6, 0.5), principled("stand_wood", (0.3, 0.2, 0.12)))
    box(scene, "tv_frame", (w / 2 - 0.06, -0.2, 1.25), (0.05, 1.32, 0.78), principled("tv_black", (0.02, 0.02, 0.02), roughness=0.2))
    plane(scene, "tv_screen", (w / 2 - 0.09, -0.2, 1.25), (1.2, 0.68), emitter("tv_picture", (0.55, 0.7, 1.0), 6.0,
          pattern="ShaderNodeTexMagic", scale=2.5), rot=(math.radians(90), 0, math.radians(-90)))
    box(scene, "side_table", (0.95, d / 2 - 0.45, 0.3), (0.4, 0.4, 0.6), principled("side_table_white", (0.7, 0.7, 0.7)))
    sphere(scene, "orb_lamp", (0.95, d / 2 - 0.45, 0.78), 0.16, emitter("orb_warm", (1.0, 0.75, 0.45), 10.0))
    art.world_colour(scene, (0.0, 0.0, 0.0), 0.0)
    camera(scene, (-1.2, -1.85, 1.5), (1.0, 1.0, 0.8), lens=20.0)


def build_product_shot(scene) -> None:
    """A product shot: a light grey cyclorama, a striped cloth (Wave-texture stripes on a rippled grid) on its
    floor, Suzanne (glossy red plastic, roughness 0.25) and a (2, 3) torus knot (rough copper, metallic 1,
    roughness 0.35) on the cloth; lit by ONE 1.2 x 0.8 m area light; a black world."""
    art.cyclorama(scene, principled("cyclorama_grey", (0.7, 0.7, 0.7), roughness=0.7))
    rippled_cloth(scene, "cloth", stripes("cloth_stripes", (0.8, 0.75, 0.6), (0.1, 0.22, 0.45), 3.0),
                  (0.0, 0.1, 0.0), (2.0, 1.4))
    suzanne(scene, "suzanne", principled("plastic_red", (0.7, 0.05, 0.04), roughness=0.25), (-0.45, 0.15, 0.42),
            0.42, rot_z=math.radians(20))
    knot = torus_knot(scene, "torus_knot", principled("copper_rough", (0.95, 0.64, 0.54), roughness=0.35, metallic=1.0),
                      (0.5, 0.25, 0.43))
    knot.rotation_euler = (math.radians(70), 0, math.radians(-15))
    light(scene, "area_key", "AREA", (-1.4, -1.6, 2.3), 220.0, target=(0.0, 0.2, 0.3), size=1.2, size_y=0.8)
    art.world_colour(scene, (0.0, 0.0, 0.0), 0.0)
    camera(scene, (0.0, -2.9, 1.0), (0.0, 0.25, 0.4), lens=45.0)


def _shelf(scene, x, y, mats):
    """A 1.6 m bookshelf against the left wall at (x, y): two sides, five boards, books (boxes in a fixed
    pattern of sizes and colours) and jars (cylinders)."""
    wood, books, glass = mats
    depth, width, top = 0.3, 1.2, 1.6
    for side in (-1, 1):
        box(scene, f"shelf_side{side + 1}", (x, y + side * (width / 2 + 0.01), top / 2), (depth, 0.02, top), wood)
    sizes = ((0.035, 0.24), (0.05, 0.28), (0.03, 0.22), (0.045, 0.26), (0.04, 0.2), (0.055, 0.27))
    for k in range(5):
        z = 0.02 + k * 0.38
        box(scene, f"shelf_board{k}", (x, y, z), (depth, width, 0.025), wood)
        if k == 4:
            break
        yy, i = y - width / 2 + 0.03, 0
        while yy < y + (0.1 if k % 2 else width / 2 - 0.1):
            bw, bh = sizes[(i + k) % len(sizes)]
            box(scene, f"book_{k}_{i}", (x + 0.01, yy + bw / 2, z + 0.0125 + bh / 2), (0.22, bw, bh), books[(i * 3 + k) % len(books)])
            yy, i = yy + bw + 0.004, i + 1
        if k % 2:
            for j in range(2):
                r, hh = 0.05 + 0.01 * j, 0.14 + 0.04 * j
                cylinder(scene, f"jar_{k}_{j}", (x, y + 0.25 + 0.16 * j, z + 0.0125 + hh / 2), r, r, hh, glass[j], segments=20)


def build_furnished_room(scene) -> None:
    """A 4.5 x 4 x 2.6 m room full of small objects, lit only by a gradient sky through one 1.6 x 1.3 m window
    (no sun, no lamps): a bookshelf with 50-odd books and four jars, a table with cups and plates, a chair, a
    sideboard with a vase, a patterned rug."""
    w, d, h, t = 4.5, 4.0, 2.6, 0.15
    paint = principled("wall_paint_green", (0.62, 0.7, 0.6))
    art._room_shell(scene, (principled("floor_oak", (0.42, 0.28, 0.16), roughness=0.3),
                            principled("ceiling_white", (0.85, 0.85, 0.85)), paint), w, d, h, t, skip=("wall_back",))
    art.box_with_hole(scene, "wall_back", (0, d / 2 + t / 2, h / 2), (w + 2 * t, t, h), paint, (-0.2, 1.4, 0.8, 2.1))
    books = [principled(f"book_{n}", c, roughness=0.6) for n, c in (("red", (0.55, 0.08, 0.06)), ("blue", (0.08, 0.15, 0.45)),
             ("cream", (0.8, 0.75, 0.6)), ("green", (0.1, 0.35, 0.15)), ("black", (0.04, 0.04, 0.04)))]
    glass = [principled("jar_amber", (0.7, 0.4, 0.1), roughness=0.1), principled("jar_teal", (0.1, 0.5, 0.5), roughness=0.1)]
    wood = principled("shelf_wood", (0.35, 0.22, 0.12), roughness=0.5)
    _shelf(scene, -w / 2 + 0.16, 0.4, (wood, books, glass))
    table(scene, "table", (0.4, -0.1, 0), (1.2, 0.8), 0.74, wood)
    china = principled("china_white", (0.85, 0.85, 0.82), roughness=0.15)
    mug = principled("mug_yellow", (0.8, 0.6, 0.1), roughness=0.3)
    for i, (cx, cy) in enumerate(((0.05, -0.3), (0.75, -0.3), (0.05, 0.15), (0.75, 0.15))):
        cylinder(scene, f"plate{i}", (cx, cy, 0.745), 0.11, 0.12, 0.012, china, segments=24)
        cylinder(scene, f"cup{i}", (cx + 0.16, cy + 0.08, 0.785), 0.035, 0.04, 0.09, mug if i % 2 else china, segments=16)
    cylinder(scene, "teapot", (0.4, -0.05, 0.82), 0.08, 0.06, 0.16, principled("teapot_blue", (0.15, 0.25, 0.6), roughness=0.2))
    chair = principled("chair_wood", (0.5, 0.32, 0.18), roughness=0.5)
    table(scene, "chair", (0.4, -0.85, 0), (0.44, 0.42), 0.45, chair, leg=0.04)
    box(scene, "chair_back", (0.4, -1.05, 0.72), (0.44, 0.03, 0.5), chair)
    box(scene, "sideboard", (w / 2 - 0.25, 0.9, 0.4), (0.45, 1.4, 0.8), principled("sideboard_white", (0.88, 0.88, 0.86)))
    cylinder(scene, "vase", (w / 2 - 0.25, 0.6, 0.95), 0.07, 0.05, 0.3, principled("vase_red", (0.6, 0.1, 0.08), roughness=0.2))
    box(scene, "rug", (0.4, -0.1, 0.005), (2.2, 1.6, 0.01),
        textured("rug_checker", (0.7, 0.55, 0.35), "ShaderNodeTexChecker", 3.0, colour2=(0.35, 0.12, 0.1), roughness=0.95))
    art.world_gradient(scene, ground=(0.15, 0.14, 0.12), horizon=(0.9, 0.92, 1.0), zenith=(0.4, 0.55, 0.9), strength=4.0)
    camera(scene, (1.9, -1.8, 1.55), (-0.9, 0.9, 0.8), lens=19.0)


def build_staircase(scene) -> None:
    """A 3 x 6 m stairwell two floors (5.6 m) high: 14 steps (0.2 m rise, 0.25 m run) along the left wall from
    the ground floor to a 1 m deep upper landing with a railing; lit only by a Sun light and a gradient sky
    through a 2 x 1.2 m skylight over the landing, the sun falling on the upper back wall, so the lower steps
    and the ground floor get mostly bounce light."""
    w, d, h, t = 3.0, 6.0, 5.6, 0.15
    plaster = diffuse("plaster", (0.78, 0.76, 0.72))
    art._room_shell(scene, (principled("ground_floor_stone", (0.45, 0.43, 0.4), roughness=0.6), plaster, plaster),
                    w, d, h, t, skip=("ceiling",))
    art.box_with_hole(scene, "ceiling", (0, 0, h + t / 2), (w + 2 * t, d + 2 * t, t), plaster, (-1.0, 1.0, 1.6, 2.8),
                      axes=(0, 1))
    wood = principled("stair_oak", (0.5, 0.33, 0.18), roughness=0.4)
    rise, run, steps, y0 = 0.2, 0.25, 14, -1.5
    for i in range(steps):
        top = rise * (i + 1)
        box(scene, f"step{i:02d}", (-w / 2 + 0.5, y0 + run * (i + 0.5), top / 2), (1.0, run, top), wood)
    upper = rise * steps
    y1 = y0 + run * steps
    box(scene, "landing", (0, (y1 + d / 2) / 2, upper - 0.1), (w, d / 2 - y1, 0.2), wood)
    metal = principled("railing_black", (0.05, 0.05, 0.05), roughness=0.3, metallic=1.0)
    box(scene, "railing", (0.5, y1 + 0.02, upper + 0.9), (2.0, 0.04, 0.04), metal)
    for i in range(6):
        box(scene, f"baluster{i}", (-0.45 + 0.38 * i, y1 + 0.02, upper + 0.45), (0.02, 0.02, 0.9), metal)
    box(scene, "door_upper", (0.6, d / 2 - 0.02, upper + 1.0), (0.9, 0.04, 2.0), principled("door_white", (0.9, 0.9, 0.9)))
    box(scene, "bench", (w / 2 - 0.25, -1.0, 0.22), (0.4, 1.2, 0.44), principled("bench_blue", (0.15, 0.25, 0.5)))
    sun_through(scene, "sun", 10.0, 65.0, 0.0)
    art.world_gradient(scene, ground=(0.15, 0.14, 0.12), horizon=(0.85, 0.9, 1.0), zenith=(0.35, 0.5, 0.9), strength=2.0)
    camera(scene, (0.9, -2.8, 1.4), (-0.6, 1.2, 2.4), lens=16.0)


def build_bathroom(scene) -> None:
    """A small 2.4 x 2.8 x 2.4 m bathroom: checker-tiled walls, a brick-pattern tiled floor (grout as mortar), a
    mirror over the basin (metallic 1, roughness 0.0), a basin on a vanity, a bathtub (five boxes), a towel rail;
    lit only by a ceiling lamp (a 30 cm area light) in a black world."""
    w, d, h = 2.4, 2.8, 2.4
    tiles = textured("wall_tiles", (0.85, 0.87, 0.88), "ShaderNodeTexChecker", 6.5, colour2=(0.35, 0.55, 0.6),
                     roughness=0.15)
    floor = textured("floor_tiles", (0.5, 0.5, 0.52), "ShaderNodeTexBrick", 2.0, colour2=(0.42, 0.42, 0.45),
                     roughness=0.4, Mortar=(0.8, 0.8, 0.78, 1.0))
    art._room_shell(scene, (floor, principled("ceiling_white", (0.9, 0.9, 0.9)), tiles), w, d, h)
    porcelain = principled("porcelain", (0.9, 0.9, 0.9), roughness=0.1)
    box(scene, "vanity", (-0.5, d / 2 - 0.25, 0.4), (0.8, 0.5, 0.8), principled("vanity_wood", (0.4, 0.27, 0.15)))
    box(scene, "basin", (-0.5, d / 2 - 0.27, 0.87), (0.55, 0.4, 0.14), porcelain)
    cylinder(scene, "tap", (-0.5, d / 2 - 0.06, 1.0), 0.015, 0.015, 0.12, principled("chrome", (0.9, 0.9, 0.9), roughness=0.05, metallic=1.0), segments=12)
    plane(scene, "mirror", (-0.5, d / 2 - 0.005, 1.55), (0.7, 0.8),
          principled("mirror", (0.95, 0.95, 0.95), roughness=0.0, metallic=1.0), rot=(math.radians(90), 0, 0))
    tx, ty, tl, tw, th, s = w / 2 - 0.38, -0.1, 1.7, 0.75, 0.55, 0.06  # the tub: centre, length, width, height, side
    for name, c, dims in (("bathtub_floor", (tx, ty, 0.04), (tw, tl, 0.08)),
                          ("bathtub_side_in", (tx - tw / 2 + s / 2, ty, th / 2), (s, tl, th)),
                          ("bathtub_side_wall", (tx + tw / 2 - s / 2, ty, th / 2), (s, tl, th)),
                          ("bathtub_end_front", (tx, ty - tl / 2 + s / 2, th / 2), (tw - 2 * s, s, th)),
                          ("bathtub_end_back", (tx, ty + tl / 2 - s / 2, th / 2), (tw - 2 * s, s, th))):
        box(scene, name, c, dims, porcelain)
    box(scene, "towel", (-w / 2 + 0.03, 0.25, 1.1), (0.04, 0.5, 0.6), principled("towel_orange", (0.8, 0.35, 0.1), roughness=1.0))
    light(scene, "ceiling_lamp", "AREA", (0.0, 0.2, h - 0.03), 15.0, target=(0.0, 0.2, 0.0), size=0.3)
    cylinder(scene, "lamp_fixture", (0.0, 0.2, h - 0.01), 0.2, 0.2, 0.02, principled("fixture_white", (0.9, 0.9, 0.9)))
    art.world_colour(scene, (0.0, 0.0, 0.0), 0.0)
    camera(scene, (-0.85, -1.2, 1.6), (0.35, 0.9, 0.9), lens=16.0)


BUILDERS = {n: globals()[f"build_{n}"] for n in NAMES}


def build(name: str, size=DEFAULT_SIZE):
    """Blender reset to an empty file, held-out scene ``name`` built into it at ``size``; the scene."""
    return art.build_from(BUILDERS, name, size, kind="held-out")


def contact_sheet(names, look_dir, out, scale=0.75) -> Path:
    """The --look PNGs of ``names`` (EEVEE | Cycles each) stacked top to bottom in that order, scaled by
    ``scale`` and reduced to 256 colours, written to ``out``."""
    from PIL import Image
    rows = [Image.open(Path(look_dir) / f"{n}.png").convert("RGB") for n in names]
    rows = [r.resize((round(r.width * scale), round(r.height * scale)), Image.LANCZOS) for r in rows]
    sheet = Image.new("RGB", (max(r.width for r in rows), sum(r.height for r in rows) + 4 * (len(rows) - 1)), "white")
    y = 0
    for r in rows:
        sheet.paste(r, (0, y))
        y += r.height + 4
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    sheet.quantize(256, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)
    return out


def main(argv=None) -> int:
    ap = art.scene_arguments("Build the held-out scenes as .blend files or look at them (score them only before a "
                             "change is resolved).", NAMES)
    ap.add_argument("--sheet", metavar="PNG", help="with --look: all scenes' PNGs stacked into one contact sheet")
    a = ap.parse_args(argv)
    if not (a.out or a.look):
        ap.error("give --out DIR or --look DIR")
    art.save_and_look(a, build=build)
    if a.look and a.sheet:
        print(contact_sheet(a.names, a.look, a.sheet), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
