"""The artist test set: five small artist-style scenes that no training room resembles, built
by script (deterministic: no randomness) and saved as .blend files for ``cli.py report --scenes`` / ``cli.py bake
--scenes`` (each file: one camera at frame 1, EEVEE with ray tracing + fast GI at 16 samples, view "Standard").

    .venv/bin/python -m scenes.artist --out DIR [--size 320x180] [--names living_room studio ...]
    .venv/bin/python -m scenes.artist --look docs/artist_scenes [--size 320x180]   # EEVEE | Cycles PNGs
    .venv/bin/python -m scenes.artist --agreement [--spp 128]   # two Cycles seeds: PSNR, seconds

Scenes (``NAMES``): living_room, studio, exterior, cornell_emissive, closed_room; docs/artist_scenes.md says
what each holds and what they look like. API: ``build_<name>(scene)`` fills an emptied scene; ``build(name,
size)`` resets Blender to an empty file, builds, returns the scene; ``save(scene, path)`` writes atomically;
``tiny_material_scene(scene)`` builds the tiny emissive/metal/glass/glossy scene and returns its object names.

Over 400 lines on purpose: the scenes, the few building blocks only they use, and the two measurements of
them (--look, --agreement) are one test set.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import bpy  # noqa: E402

import scenes  # noqa: E402  (the checkout as package ssgi)
import bmesh  # noqa: E402  (after bpy: bpy makes it importable)
from mathutils import Vector  # noqa: E402

NAMES = ("living_room", "studio", "exterior", "cornell_emissive", "closed_room")
DEFAULT_SIZE = (320, 180)
EEVEE_SAMPLES = 16
CYCLES_SAMPLES = 128  # saved in the file (the report and the bake set their own)

# ------------------------------------------------------------------------------------------ building blocks


def principled(name, base=(0.8, 0.8, 0.8), roughness=0.5, metallic=0.0, specular=0.5, transmission=0.0,
               alpha=1.0, ior=1.5, emission=None, strength=0.0, texture=None):
    """A Principled BSDF material at Blender's defaults except what is given. ``texture``: a shader node type
    (e.g. "ShaderNodeTexChecker") on Base Color, in object coordinates, with its own ``Color1/Color2`` from
    ``base`` and a darker shade."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    p = nt.nodes.get("Principled BSDF")
    vals = {"Base Color": (*base, 1.0), "Roughness": roughness, "Metallic": metallic, "Specular IOR Level": specular,
            "Transmission Weight": transmission, "Alpha": alpha, "IOR": ior, "Emission Strength": strength}
    if emission is not None:
        vals["Emission Color"] = (*emission, 1.0)
    for k, v in vals.items():
        p.inputs[k].default_value = v
    if texture:
        tc = nt.nodes.new("ShaderNodeTexCoord")
        tx = nt.nodes.new(texture)
        tx.inputs["Scale"].default_value = 6.0
        if "Color1" in tx.inputs:
            tx.inputs["Color1"].default_value = (*base, 1.0)
            tx.inputs["Color2"].default_value = (*(c * 0.25 for c in base), 1.0)
        nt.links.new(tc.outputs["Object"], tx.inputs["Vector"])
        nt.links.new(tx.outputs["Color"], p.inputs["Base Color"])
    if transmission > 0:
        m.use_raytrace_refraction = True  # EEVEE refracts through the object (an artist's glass setting)
    m.diffuse_color = (*base, 1.0)
    return m


def diffuse(name, base):
    """Principled, fully rough with no specular: a diffuse surface."""
    return principled(name, base, roughness=1.0, specular=0.0)


def _object(scene, name, bm, mat=None, loc=(0, 0, 0), rot=(0, 0, 0), smooth=False):
    me = bpy.data.meshes.new(name)
    if smooth:
        for f in bm.faces:
            f.smooth = True
    bm.to_mesh(me)
    bm.free()
    if mat is not None:
        me.materials.append(mat)
    o = bpy.data.objects.new(name, me)
    o.location, o.rotation_euler = loc, rot
    scene.collection.objects.link(o)
    return o


def box(scene, name, center, dims, mat, rot_z=0.0):
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bmesh.ops.scale(bm, vec=dims, verts=bm.verts)
    return _object(scene, name, bm, mat, center, (0, 0, rot_z))


def sphere(scene, name, center, radius, mat):
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=radius)
    return _object(scene, name, bm, mat, center, smooth=True)


def cylinder(scene, name, center, r_bottom, r_top, height, mat, caps=True, segments=40):
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=caps, segments=segments, radius1=r_bottom, radius2=r_top, depth=height)
    return _object(scene, name, bm, mat, center, smooth=True)


def plane(scene, name, center, size, mat, rot=(0, 0, 0)):
    """A plane of ``size`` (sx, sy) facing +Z before ``rot``."""
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=0.5)
    bmesh.ops.scale(bm, vec=(size[0], size[1], 1.0), verts=bm.verts)
    return _object(scene, name, bm, mat, center, rot)


def box_with_hole(scene, name, center, dims, mat, hole, axes=(0, 2)):
    """A slab ``box`` with a rectangular hole (a window in a wall, a skylight in a ceiling) as four boxes
    ``<name>_left/_right/_below/_above``: ``hole`` = (a0, a1, b0, b1) in world coordinates along ``axes``
    (x and z for a wall facing y, x and y for a ceiling); "below" and "above" are along the second axis."""
    (i, j), c, dm = axes, list(center), list(dims)
    lo_a, hi_a, lo_b, hi_b = c[i] - dm[i] / 2, c[i] + dm[i] / 2, c[j] - dm[j] / 2, c[j] + dm[j] / 2
    a0, a1, b0, b1 = hole
    parts = {"left": ((lo_a + a0) / 2, a0 - lo_a, c[j], dm[j]), "right": ((a1 + hi_a) / 2, hi_a - a1, c[j], dm[j]),
             "below": ((a0 + a1) / 2, a1 - a0, (lo_b + b0) / 2, b0 - lo_b),
             "above": ((a0 + a1) / 2, a1 - a0, (b1 + hi_b) / 2, hi_b - b1)}
    out = {}
    for part, (ca, da, cb, db) in parts.items():
        pc, pd = list(c), list(dm)
        pc[i], pd[i], pc[j], pd[j] = ca, da, cb, db
        out[part] = box(scene, f"{name}_{part}", tuple(pc), tuple(pd), mat)
    return out


def cyclorama(scene, mat, name="cyclorama", half_width=4.0, front=-4.0, cove_y=1.0, radius=1.5, height=4.0,
              steps=16):
    """A photo studio's curved backdrop, x in [-half_width, half_width]: a floor from y = ``front`` to
    ``cove_y``, a quarter circle of ``radius`` (``steps`` faces) up to a back wall at y = cove_y + radius,
    ``height`` tall."""
    r, yc, zc, n = radius, cove_y, radius, steps
    prof = [(front, 0.0), (yc, 0.0)]
    prof += [(yc + r * math.sin(a), zc - r * math.cos(a)) for a in (math.pi / 2 * i / n for i in range(1, n + 1))]
    prof += [(yc + r, height)]
    bm = bmesh.new()
    rows = [[bm.verts.new((x, y, z)) for y, z in prof] for x in (-half_width, half_width)]
    for i in range(len(prof) - 1):
        bm.faces.new((rows[0][i], rows[1][i], rows[1][i + 1], rows[0][i + 1]))
    return _object(scene, name, bm, mat, smooth=True)


def aim(obj, target) -> None:
    """Point the object's -Z (cameras, lights) at ``target``."""
    d = Vector(target) - Vector(obj.location)
    obj.rotation_euler = d.to_track_quat("-Z", "Y").to_euler()


def camera(scene, loc, target, lens=28.0, name="camera"):
    cam = bpy.data.objects.new(name, bpy.data.cameras.new(name))
    cam.data.lens = lens
    cam.data.clip_start, cam.data.clip_end = 0.05, 500.0
    cam.location = loc
    aim(cam, target)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def light(scene, name, kind, loc, energy, target=None, size=0.0, size_y=None, angle_deg=None, colour=(1, 1, 1)):
    li = bpy.data.lights.new(name, kind)
    li.energy, li.color = energy, colour
    if kind == "AREA":
        li.shape = "SQUARE" if size_y is None else "RECTANGLE"
        li.size = size
        if size_y is not None:
            li.size_y = size_y
    elif kind in ("POINT", "SPOT"):
        li.shadow_soft_size = size
    if angle_deg is not None:
        li.angle = math.radians(angle_deg)
    o = bpy.data.objects.new(name, li)
    o.location = loc
    if target is not None:
        aim(o, target)
    scene.collection.objects.link(o)
    return o


def _world(scene, name):
    w = bpy.data.worlds.new(name)
    w.use_nodes = True
    scene.world = w
    nt = w.node_tree
    return w, nt, nt.nodes.get("Background") or nt.nodes.new("ShaderNodeBackground")


def world_colour(scene, rgb, strength=1.0):
    w, _nt, bg = _world(scene, "world")
    bg.inputs["Color"].default_value = (*rgb, 1.0)
    bg.inputs["Strength"].default_value = strength
    w.color = rgb
    return w


def world_gradient(scene, ground, horizon, zenith, strength=1.0):
    """A sky gradient on the view direction's height: ``ground`` below the horizon, ``horizon`` to ``zenith``."""
    w, nt, bg = _world(scene, "sky_gradient")
    tc, sep = nt.nodes.new("ShaderNodeTexCoord"), nt.nodes.new("ShaderNodeSeparateXYZ")
    rng, ramp = nt.nodes.new("ShaderNodeMapRange"), nt.nodes.new("ShaderNodeValToRGB")
    nt.links.new(tc.outputs["Generated"], sep.inputs["Vector"])
    rng.inputs["From Min"].default_value, rng.inputs["From Max"].default_value = -1.0, 1.0
    nt.links.new(sep.outputs["Z"], rng.inputs["Value"])
    nt.links.new(rng.outputs["Result"], ramp.inputs["Fac"])
    els = ramp.color_ramp.elements
    els[0].position, els[0].color = 0.0, (*ground, 1.0)
    els[1].position, els[1].color = 1.0, (*zenith, 1.0)
    for pos, c in ((0.49, ground), (0.5, horizon)):
        e = els.new(pos)
        e.color = (*c, 1.0)
    nt.links.new(ramp.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = strength
    w.color = horizon
    return w


def world_sky(scene, sun_elevation_deg, sun_rotation_deg, strength):
    """Blender's Sky Texture (its default model) without the sun disc: the sun is a Sun light."""
    w, nt, bg = _world(scene, "sky")
    sky = nt.nodes.new("ShaderNodeTexSky")
    sky.sun_disc = False
    sky.sun_elevation, sky.sun_rotation = math.radians(sun_elevation_deg), math.radians(sun_rotation_deg)
    nt.links.new(sky.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = strength
    return w


def render_settings(scene, size=DEFAULT_SIZE) -> None:
    """What each file saves: EEVEE with ray tracing + fast GI at 16 samples, view Standard, ``size`` at 100 %,
    Cycles at sane settings (its samples are the report's/bake's own)."""
    r = scene.render
    r.engine = "BLENDER_EEVEE"
    r.resolution_x, r.resolution_y = int(size[0]), int(size[1])
    r.resolution_percentage = 100
    ee = scene.eevee
    ee.use_raytracing = True
    ee.use_fast_gi = True
    ee.taa_render_samples = EEVEE_SAMPLES
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
    c = scene.cycles
    c.samples = CYCLES_SAMPLES
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 8, 4, 4
    c.transmission_bounces, c.transparent_max_bounces = 8, 8
    scene.frame_start = scene.frame_end = scene.frame_current = 1


# ------------------------------------------------------------------------------------------ the five scenes


def _room_shell(scene, mats, w, d, h, t=0.15, skip=()):
    """Walls, floor and ceiling of a closed room x in [-w/2, w/2], y in [-d/2, d/2], z in [0, h] as boxes of
    thickness ``t`` (closed to Cycles' rays from outside); ``mats``: floor, ceiling, walls."""
    fl, ce, wa = mats
    parts = {"floor": ((0, 0, -t / 2), (w + 2 * t, d + 2 * t, t), fl),
             "ceiling": ((0, 0, h + t / 2), (w + 2 * t, d + 2 * t, t), ce),
             "wall_left": ((-w / 2 - t / 2, 0, h / 2), (t, d, h), wa),
             "wall_right": ((w / 2 + t / 2, 0, h / 2), (t, d, h), wa),
             "wall_front": ((0, -d / 2 - t / 2, h / 2), (w + 2 * t, t, h), wa),
             "wall_back": ((0, d / 2 + t / 2, h / 2), (w + 2 * t, t, h), wa)}
    return {k: box(scene, k, *v) for k, v in parts.items() if k not in skip}


def build_living_room(scene) -> None:
    """5 x 4 x 2.6 m room, default Principled materials, a glossy wooden floor, a checker-textured armchair, a
    floor lamp (a thin metal pole, an emissive shade: the only light besides the window) and a window in the
    back wall onto a gradient sky."""
    w, d, h, t = 5.0, 4.0, 2.6, 0.15
    wall = principled("wall_paint", (0.80, 0.77, 0.70))
    floor = principled("wood_floor", (0.32, 0.19, 0.10), roughness=0.08)
    _room_shell(scene, (floor, principled("ceiling_paint", (0.85, 0.85, 0.85)), wall), w, d, h, t,
                skip=("wall_back",))
    # the back wall with a 1.6 x 1.2 m window, its sill at 0.9 m, centred at x = 0.6
    box_with_hole(scene, "wall_back", (0, d / 2 + t / 2, h / 2), (w + 2 * t, t, h), wall, (-0.2, 1.4, 0.9, 2.1))
    fabric = principled("armchair_fabric", (0.55, 0.12, 0.10), roughness=0.8, texture="ShaderNodeTexChecker")
    box(scene, "armchair_seat", (-0.9, 1.0, 0.22), (0.9, 0.8, 0.44), fabric, rot_z=math.radians(20))
    box(scene, "armchair_back", (-1.03, 1.35, 0.6), (0.9, 0.2, 0.7), fabric, rot_z=math.radians(20))
    box(scene, "sideboard", (1.6, -0.6, 0.4), (0.45, 1.6, 0.8), principled("sideboard_white", (0.9, 0.9, 0.88)))
    cylinder(scene, "vase", (1.6, -0.3, 0.95), 0.09, 0.06, 0.3, principled("vase_blue", (0.1, 0.25, 0.6), roughness=0.2))
    rug = principled("rug", (0.75, 0.65, 0.45), roughness=0.9, texture="ShaderNodeTexWave")
    box(scene, "rug", (0.0, 0.3, 0.005), (2.0, 1.4, 0.01), rug)
    metal = principled("brushed_steel", (0.8, 0.8, 0.8), roughness=0.25, metallic=1.0)
    lx, ly = -1.85, 1.2
    cylinder(scene, "lamp_base", (lx, ly, 0.015), 0.16, 0.16, 0.03, metal)
    cylinder(scene, "lamp_pole", (lx, ly, 0.8), 0.012, 0.012, 1.6, metal, segments=16)
    shade = principled("lamp_shade", (1.0, 0.85, 0.6), roughness=0.7, emission=(1.0, 0.72, 0.42), strength=8.0)
    cylinder(scene, "lamp_shade", (lx, ly, 1.6), 0.28, 0.18, 0.32, shade, caps=False)
    world_gradient(scene, ground=(0.12, 0.11, 0.09), horizon=(0.85, 0.9, 1.0), zenith=(0.3, 0.5, 0.95), strength=1.0)
    camera(scene, (1.9, -1.75, 1.45), (-0.6, 1.2, 0.9), lens=22.0)


def build_studio(scene) -> None:
    """A product shot: a white cyclorama, a gold sphere (metallic 1, roughness 0.2), a glass cylinder
    (transmission 1), a sheet of tinted transparent film (alpha 0.35), two big area lights; film transparent."""
    cyclorama(scene, principled("cyclorama_white", (0.8, 0.8, 0.8)))
    gold = principled("gold", (1.0, 0.766, 0.336), roughness=0.2, metallic=1.0)
    sphere(scene, "gold_sphere", (-0.55, 0.4, 0.45), 0.45, gold)
    glass = principled("glass", (1.0, 1.0, 1.0), roughness=0.0, transmission=1.0, ior=1.45)
    cylinder(scene, "glass_cylinder", (0.6, 0.55, 0.45), 0.25, 0.25, 0.9, glass)
    film = principled("transparent_film", (0.4, 0.7, 0.95), roughness=0.1, alpha=0.35)
    plane(scene, "film", (0.15, -0.45, 0.55), (0.7, 1.1), film, rot=(math.radians(90), 0, math.radians(-25)))
    box(scene, "pedestal", (0.6, 0.55, -0.0), (0.7, 0.7, 0.02), principled("pedestal_grey", (0.3, 0.3, 0.3)))
    light(scene, "softbox_key", "AREA", (-2.6, -2.0, 2.8), 110.0, target=(0, 0.3, 0.4), size=2.0)
    light(scene, "softbox_fill", "AREA", (2.8, -1.6, 1.6), 30.0, target=(0, 0.3, 0.5), size=1.5, size_y=1.0)
    world_colour(scene, (0.05, 0.05, 0.05))
    scene.render.film_transparent = True
    camera(scene, (0.0, -3.6, 1.2), (0.0, 0.4, 0.5), lens=40.0)


def build_exterior(scene) -> None:
    """Boxes for buildings on a ground plane under a Sun light (3 degree angle) and a sky; no walls."""
    sun_el, sun_rot = 35.0, 60.0
    ground = principled("asphalt_grass", (0.22, 0.24, 0.18), roughness=0.9)
    plane(scene, "ground", (0, 0, 0), (200.0, 200.0), ground)
    blds = (("building_concrete", (-6.0, 14.0, 5.0), (6.0, 6.0, 10.0), (0.6, 0.6, 0.58), 0.0),
            ("building_brick", (4.0, 18.0, 3.5), (7.0, 5.0, 7.0), (0.55, 0.22, 0.15), 0.3),
            ("building_tall", (13.0, 28.0, 11.0), (6.0, 6.0, 22.0), (0.75, 0.72, 0.62), -0.2),
            ("shed", (1.5, 8.0, 1.2), (3.0, 2.0, 2.4), (0.85, 0.82, 0.7), 0.5),
            ("wall_low", (-2.5, 6.0, 0.5), (5.0, 0.4, 1.0), (0.5, 0.48, 0.45), 0.0))
    for name, c, dims, rgb, rz in blds:
        box(scene, name, c, dims, principled(name, rgb, roughness=0.7), rot_z=rz)
    sphere(scene, "ball", (3.2, 5.0, 0.5), 0.5, principled("ball_white", (0.85, 0.85, 0.85), roughness=0.4))
    sun = light(scene, "sun", "SUN", (0, 0, 20), 1.2, angle_deg=3.0, colour=(1.0, 0.95, 0.88))
    # the light shines along its -Z: from the sun's direction (elevation, rotation as the sky's) towards the ground
    el, rot = math.radians(sun_el), math.radians(sun_rot)
    to_sun = Vector((math.cos(el) * math.sin(rot), -math.cos(el) * math.cos(rot), math.sin(el)))
    sun.rotation_euler = (-to_sun).to_track_quat("-Z", "Y").to_euler()
    world_sky(scene, sun_el, sun_rot, strength=0.06)
    camera(scene, (-3.0, -4.0, 1.7), (2.0, 12.0, 4.0), lens=24.0)


def build_cornell_emissive(scene) -> None:
    """The Cornell box (2 m, red left and green right walls, white otherwise) lit only by an emissive ceiling
    panel (no lamp objects, a black world), a mirror-metal ball (metallic 1, roughness 0.02) and a diffuse box."""
    white, red, green = diffuse("white", (0.73, 0.73, 0.73)), diffuse("red", (0.63, 0.06, 0.05)), diffuse("green", (0.12, 0.45, 0.15))
    s, t = 2.0, 0.05
    parts = {"floor": ((0, 0, -t / 2), (s + 2 * t, s + 2 * t, t), white),
             "ceiling": ((0, 0, s + t / 2), (s + 2 * t, s + 2 * t, t), white),
             "back": ((0, s / 2 + t / 2, s / 2), (s + 2 * t, t, s), white),
             "left": ((-s / 2 - t / 2, 0, s / 2), (t, s, s), red),
             "right": ((s / 2 + t / 2, 0, s / 2), (t, s, s), green)}
    for k, v in parts.items():
        box(scene, k, *v)
    panel = principled("panel_emission", (0.0, 0.0, 0.0), roughness=1.0, specular=0.0, emission=(1.0, 0.85, 0.65),
                       strength=20.0)
    plane(scene, "emissive_panel", (0, 0, s - 0.002), (0.5, 0.4), panel, rot=(math.pi, 0, 0))
    box(scene, "diffuse_box", (-0.35, 0.3, 0.6), (0.55, 0.55, 1.2), white, rot_z=math.radians(17))
    sphere(scene, "mirror_ball", (0.4, 0.05, 0.35), 0.35, principled("mirror", (0.95, 0.95, 0.95), roughness=0.02,
                                                                      metallic=1.0))
    world_colour(scene, (0.0, 0.0, 0.0), 0.0)
    camera(scene, (0, -3.0, 1.0), (0, 0, 1.0), lens=26.0)


def build_closed_room(scene) -> None:
    """The control: a closed 4 x 3.5 x 2.6 m diffuse room (Principled, roughness 1, specular 0), a few diffuse
    objects, one point light, a black world."""
    _room_shell(scene, (diffuse("floor_grey", (0.45, 0.42, 0.4)), diffuse("ceiling_white", (0.8, 0.8, 0.8)),
                        diffuse("wall_beige", (0.7, 0.62, 0.5))), 4.0, 3.5, 2.6)
    box(scene, "crate", (0.8, 0.6, 0.35), (0.7, 0.7, 0.7), diffuse("crate_blue", (0.15, 0.25, 0.6)), rot_z=0.4)
    sphere(scene, "ball", (-0.6, 0.9, 0.4), 0.4, diffuse("ball_yellow", (0.8, 0.65, 0.15)))
    cylinder(scene, "column", (-1.3, -0.2, 0.6), 0.25, 0.25, 1.2, diffuse("column_white", (0.8, 0.8, 0.8)))
    light(scene, "point", "POINT", (0.3, -0.3, 2.2), 60.0, size=0.05)
    world_colour(scene, (0.0, 0.0, 0.0), 0.0)
    camera(scene, (1.6, -1.5, 1.5), (-0.3, 0.8, 0.6), lens=22.0)


BUILDERS = {n: globals()[f"build_{n}"] for n in NAMES}


def tiny_material_scene(scene) -> dict[str, str]:
    """A tiny scene in an emptied ``scene`` (for "nothing renders black" tests): a camera, a dim world, one point
    light, a diffuse floor, an emissive panel, a metal sphere, a glass cube and a glossy (roughness 0.1) plane.
    Returns {role: object name} for camera, light, floor, emissive, metal, glass, glossy."""
    floor = plane(scene, "tiny_floor", (0, 0, 0), (6.0, 6.0), diffuse("tiny_floor_grey", (0.5, 0.5, 0.5)))
    glossy = plane(scene, "tiny_glossy", (0.0, 1.2, 0.01), (2.4, 0.8),
                   principled("tiny_glossy_red", (0.6, 0.1, 0.1), roughness=0.1))
    panel = plane(scene, "tiny_emissive", (-1.1, 0.9, 0.6), (0.5, 0.9),
                  principled("tiny_emission", (0, 0, 0), emission=(0.2, 0.6, 1.0), strength=8.0),
                  rot=(math.radians(90), 0, math.radians(20)))
    metal = sphere(scene, "tiny_metal", (-0.2, 0.2, 0.35), 0.35,
                   principled("tiny_metal_gold", (1.0, 0.77, 0.34), roughness=0.15, metallic=1.0))
    glass = box(scene, "tiny_glass", (0.75, 0.1, 0.3), (0.5, 0.5, 0.6),
                principled("tiny_glass", (1, 1, 1), roughness=0.0, transmission=1.0), rot_z=0.5)
    li = light(scene, "tiny_point", "POINT", (0.8, -1.0, 2.2), 300.0, size=0.1)
    world_colour(scene, (0.02, 0.02, 0.025))
    cam = camera(scene, (0.0, -3.0, 1.6), (0.0, 0.4, 0.3), lens=30.0, name="tiny_camera")
    render_settings(scene, (64, 36))
    scene.view_layers[0].update()
    return {"camera": cam.name, "light": li.name, "floor": floor.name, "emissive": panel.name, "metal": metal.name,
            "glass": glass.name, "glossy": glossy.name}


def build_from(builders, name: str, size, kind: str = "artist"):
    """Blender reset to an empty file, scene ``name`` built into it by ``builders[name]`` with ``render_settings``
    at ``size``; the scene. ``kind`` names the set in the error for an unknown name."""
    if name not in builders:
        raise ValueError(f"{name!r}: no such {kind} scene; scenes: {', '.join(builders)}")
    scene = scenes.empty_scene()
    scene.name = name
    builders[name](scene)
    render_settings(scene, size)
    scene.view_layers[0].update()  # the objects' matrix_world
    return scene


def build(name: str, size=DEFAULT_SIZE):
    """Blender reset to an empty file, scene ``name`` built into it at ``size``; the scene."""
    return build_from(BUILDERS, name, size)


def save(scene, path) -> Path:
    """The current file saved as ``path`` atomically (a copy: the session's file name stays)."""
    from ssgi.model import files
    path = Path(path).resolve()
    return files.atomic_write(path, lambda tmp: bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True,
                                                                             check_existing=False))


# ------------------------------------------------------------------------------------------ looking, measuring


def render_eevee(scene):
    """EEVEE at the file's own settings: the Combined image (HxWx3 linear) and seconds."""
    from ssgi.ssgi_addon.blender import passes
    scene.render.engine = "BLENDER_EEVEE"
    t = time.perf_counter()
    p = passes._render(scene)["Combined"]
    import numpy as np
    return np.stack([p[c] for c in "RGB"], axis=-1), time.perf_counter() - t


def render_cycles(scene, spp: int, seed: int = 1):
    """Cycles at ``spp`` + OIDN (passes.render_cycles): HxWx3 linear and seconds."""
    from ssgi.ssgi_addon.blender import passes
    t = time.perf_counter()
    img = passes.render_cycles(scene, spp, seed=seed, denoise=True)["ref"]
    return img, time.perf_counter() - t


def _stats(img) -> dict:
    import numpy as np
    lum = img[..., :3].mean(axis=-1)
    return dict(mean=round(float(img[..., :3].mean()), 4), over1=round(float((lum > 1.0).mean()), 4),
                under002=round(float((lum < 0.02).mean()), 4))


def look(names, size, out_dir, spp: int, build=build) -> list[dict]:
    """EEVEE (own settings) | Cycles spp + OIDN, side by side, one PNG per scene (images.srgb8) in ``out_dir``;
    ``build(name, size)`` makes each scene (this module's by default). Prints and returns one row per scene: the
    images' statistics and the seconds of each render."""
    import numpy as np
    from ssgi.model import images
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in names:
        scene = build(name, size)
        ee, t_e = render_eevee(scene)
        cy, t_c = render_cycles(scene, spp)
        gap = np.ones((ee.shape[0], 4, 3), np.float32)
        images.write_png(out_dir / f"{name}.png", images.srgb8(np.concatenate([ee, gap, cy], axis=1)))
        row = dict(scene=name, eevee=_stats(ee), cycles=_stats(cy), eevee_s=round(t_e, 1), cycles_s=round(t_c, 1))
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def agreement(names, size, spp: int) -> list[dict]:
    """Two Cycles renders (seeds 1 and 2) at ``spp`` + OIDN of each scene: PSNR (metrics.psnr) and seconds."""
    from ssgi.model import metrics
    rows = []
    for name in names:
        scene = build(name, size)
        (a, ta), (b, tb) = render_cycles(scene, spp, 1), render_cycles(scene, spp, 2)
        row = dict(scene=name, spp=spp, psnr=round(metrics.psnr(a, b), 2), seconds=round((ta + tb) / 2, 1),
                   mean=round(float(a.mean()), 4))
        rows.append(row)
        print(json.dumps(row), flush=True)
    print("| scene | PSNR seed 1 vs 2 (dB) | s per render | mean |\n|---|---|---|---|", file=sys.stderr)
    for r in rows:
        print(f"| {r['scene']} | {r['psnr']:.2f} | {r['seconds']:.1f} | {r['mean']:.3f} |", file=sys.stderr)
    return rows


def scene_arguments(description: str, names) -> argparse.ArgumentParser:
    """The command line of a scene module: --out, --size, --names (of ``names``), --look, --look-spp."""
    from ssgi.model.cliargs import parse_size
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--out", help="write OUT/<name>.blend for each scene")
    ap.add_argument("--size", type=parse_size, default=DEFAULT_SIZE, help="render size saved in the files (320x180)")
    ap.add_argument("--names", nargs="+", choices=names, default=list(names), help="scenes (default: all)")
    ap.add_argument("--look", metavar="DIR", help="render EEVEE (own settings) | Cycles + OIDN into DIR/<name>.png")
    ap.add_argument("--look-spp", type=int, default=64, help="Cycles samples of --look (64)")
    return ap


def save_and_look(a, build=build) -> None:
    """What --out and --look of ``scene_arguments`` ask for, each scene made by ``build(name, size)``."""
    size = tuple(a.size)
    if a.out:
        Path(a.out).mkdir(parents=True, exist_ok=True)
        for name in a.names:
            p = save(build(name, size), Path(a.out) / f"{name}.blend")
            print(p, flush=True)
    if a.look:
        look(a.names, size, a.look, a.look_spp, build=build)


def main(argv=None) -> int:
    ap = scene_arguments("Build the artist test set as .blend files, look at it, or measure its Cycles references' "
                         "agreement.", NAMES)
    ap.add_argument("--agreement", action="store_true", help="two Cycles seeds + OIDN per scene: PSNR, seconds")
    ap.add_argument("--spp", type=int, default=128, help="Cycles samples of --agreement (128)")
    a = ap.parse_args(argv)
    if not (a.out or a.look or a.agreement):
        ap.error("give --out DIR, --look DIR or --agreement")
    size = tuple(a.size)
    save_and_look(a)
    if a.agreement:
        agreement(a.names, size, a.spp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
