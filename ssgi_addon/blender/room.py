"""Random rooms: a box of diffuse surfaces, 3-10 diffuse primitives, 1-3 lights and a camera, from one seed.

``build_room(seed)`` draws every parameter from ``random.Random(seed)`` first (``room_params``, plain data, no
bpy) and then builds the scene from those numbers, so the same seed on the same Blender version gives the
same scene: the same object names, transforms, colours and light settings.

Everything the room adds carries the custom property ``ssgi_room`` and a name starting with ``ssgi.``;
``clear_room`` removes them again (the baker builds one room after another in one scene).
"""
from __future__ import annotations

import math
import random

import bpy
import bmesh
from mathutils import Vector

# the bpy-free pieces both modes share (room_artist.py is plain data, importable without bpy)
from .room_artist import PREFIX, SHAPES, WALLS, bsphere as _half_extent, colour as _colour  # noqa: F401

LIGHT_TYPES = ("POINT", "AREA", "SPOT")
MIN_WALL_GAP = 0.6  # the camera stays at least this far (m) from every wall
CAMERA_CLEARANCE = 0.35  # ... and this far outside every object's bounding sphere
SHADING = ("Roughness", "Specular IOR Level", "Metallic", "Transmission Weight", "Emission Strength")

# --------------------------------------------------------------------------------------------- parameters


MODES = ("diffuse", "artist", "studio", "interior")


def room_params(seed: int, mode: str = "diffuse") -> dict:
    """Every random choice of room ``seed`` as plain data (deterministic; no bpy). ``mode`` "diffuse": the
    seed's box of diffuse primitives and lamps; "artist": room_artist.py's artist scenes; "studio":
    room_studio.py's cycloramas lit by softboxes; "interior": room_interior.py's bright plaster rooms."""
    if mode == "artist":
        from .room_artist import artist_params
        return artist_params(seed)
    if mode == "studio":
        from .room_studio import studio_params
        return studio_params(seed)
    if mode == "interior":
        from .room_interior import interior_params
        return interior_params(seed)
    if mode != "diffuse":
        raise ValueError(f"room mode {mode!r}: expected one of {', '.join(MODES)}")
    rng = random.Random(int(seed))
    W, D, H = rng.uniform(3.5, 7.0), rng.uniform(3.5, 7.0), rng.uniform(2.5, 3.8)
    surfaces = {w: _colour(rng, 0.8, 0.2, 0.85) for w in WALLS}
    open_side = None
    if rng.random() < 0.3:
        open_side = rng.choice(("wall_xn", "wall_xp", "wall_yn", "wall_yp"))
    world = dict(colour=_colour(rng, 0.5, 0.6, 1.0), strength=round(rng.uniform(0.3, 1.0), 6))

    # objects: near the middle of the room so that the camera has space around them
    objects = []
    n_obj = rng.randint(3, 10)
    cx, cy = rng.uniform(-0.15, 0.15) * W, rng.uniform(-0.15, 0.15) * D
    for i in range(n_obj):
        shape = rng.choice(SHAPES)
        size = rng.uniform(0.18, 0.6)
        sx = size * rng.uniform(0.7, 1.3)
        sy = size * rng.uniform(0.7, 1.3)
        sz = size * rng.uniform(0.7, 1.5)
        floating = rng.random() < 0.35
        x = cx + rng.uniform(-0.3, 0.3) * W
        y = cy + rng.uniform(-0.3, 0.3) * D
        if floating:
            rot = (rng.uniform(0, math.tau), rng.uniform(0, math.tau), rng.uniform(0, math.tau))
            z = rng.uniform(0.6, H - 0.7)
        else:
            rot = (0.0, 0.0, rng.uniform(0, math.tau))
            z = sz * (0.984 if shape == "monkey" else 1.0)  # unit meshes span z in [-1, 1] (Suzanne +-0.984)
        objects.append(dict(name=f"{PREFIX}obj.{i:02d}.{shape}", shape=shape, location=(x, y, z),
                            rotation=rot, scale=(sx, sy, sz), floating=floating,
                            radius=_half_extent(shape, max(sx, sy, sz)), colour=_colour(rng)))
    target = (sum(o["location"][0] for o in objects) / n_obj, sum(o["location"][1] for o in objects) / n_obj,
              min(H * 0.45, sum(o["location"][2] for o in objects) / n_obj))

    def free(p, margin):
        return all((Vector(p) - Vector(o["location"])).length > o["radius"] + margin for o in objects)

    def inside(margin):
        return (rng.uniform(-W / 2 + margin, W / 2 - margin), rng.uniform(-D / 2 + margin, D / 2 - margin),
                rng.uniform(margin, H - margin))

    # lights: inside the room, outside every object
    lights = []
    n_light = rng.randint(1, 3)
    scale = (W * D + W * H + D * H) / 3.0  # ~ squared room size: keeps exposure similar across room sizes
    for i in range(n_light):
        kind = rng.choice(LIGHT_TYPES)
        for _ in range(200):
            p = inside(0.35)
            p = (p[0], p[1], rng.uniform(0.55, 0.92) * H)
            if free(p, 0.3):
                break
        # ~ W per m^2 of room: measured (benchmarks/ref_agreement.py) to give Cycles references with a mean
        # linear value of ~0.1-0.6, so that the seed's [0,1]-clamped PSNR sees most pixels unclipped
        power = scale * rng.uniform(2.0, 8.0) / n_light ** 0.5
        d = dict(name=f"{PREFIX}light.{i}.{kind.lower()}", type=kind, location=p,
                 colour=_colour(rng, 0.55, 1.0, 1.0), energy=round(power, 4), radius=round(rng.uniform(0.05, 0.4), 6))
        aim = Vector(target) + Vector((rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0.0))
        if kind == "SPOT":
            d["spot_size"] = round(math.radians(rng.uniform(60.0, 120.0)), 6)
            d["spot_blend"] = round(rng.uniform(0.05, 0.5), 6)
            d["energy"] = round(power * 1.5, 4)
        elif kind == "AREA":
            d["shape"] = rng.choice(("SQUARE", "RECTANGLE", "DISK", "ELLIPSE"))
            d["size"] = round(rng.uniform(0.3, 1.4), 6)
            d["size_y"] = round(d["size"] * rng.uniform(0.4, 1.0), 6) if d["shape"] in ("RECTANGLE", "ELLIPSE") else d["size"]
            d["energy"] = round(power * 1.5, 4)
            aim = Vector((p[0], p[1], 0.0)).lerp(aim, 0.5)  # mostly downwards
        d["rotation"] = tuple((aim - Vector(p)).to_track_quat("-Z", "Y").to_euler())
        lights.append(d)

    # camera: inside the room, away from the walls and outside the objects, looking at the objects
    lens = rng.uniform(18.0, 32.0)
    for _ in range(500):
        p = inside(MIN_WALL_GAP)
        p = (p[0], p[1], rng.uniform(0.5, min(2.0, H - MIN_WALL_GAP)))
        dist = (Vector(p) - Vector(target)).length
        if free(p, CAMERA_CLEARANCE) and dist > 1.5:
            break
    look = Vector(target) + Vector((rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-0.2, 0.3)))
    rot = (look - Vector(p)).to_track_quat("-Z", "Y").to_euler()
    camera = dict(name=f"{PREFIX}camera", location=p, rotation=tuple(rot), lens=round(lens, 6))
    return dict(seed=int(seed), size=(W, D, H), surfaces=surfaces, open_side=open_side, world=world,
                objects=objects, lights=lights, camera=camera)


# --------------------------------------------------------------------------------------------- building


def diffuse_material(name: str, colour) -> bpy.types.Material:
    """A purely diffuse Principled BSDF: roughness 1, specular (IOR level) 0."""
    m = bpy.data.materials.new(name)
    m["ssgi_room"] = True
    nt = m.node_tree
    if nt is None:  # Blender < 5 needed use_nodes
        m.use_nodes = True
        nt = m.node_tree
    p = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    p.inputs["Base Color"].default_value = (*colour, 1.0)
    p.inputs["Roughness"].default_value = 1.0
    p.inputs["Specular IOR Level"].default_value = 0.0
    p.inputs["Metallic"].default_value = 0.0
    m.diffuse_color = (*colour, 1.0)
    return m


def _mesh(shape: str, name: str) -> bpy.types.Mesh:
    bm = bmesh.new()
    if shape == "cube":
        bmesh.ops.create_cube(bm, size=2.0)
    elif shape == "cone":
        bmesh.ops.create_cone(bm, cap_ends=True, cap_tris=False, segments=32, radius1=1.0, radius2=0.0, depth=2.0)
    elif shape == "cylinder":
        bmesh.ops.create_cone(bm, cap_ends=True, cap_tris=False, segments=32, radius1=1.0, radius2=1.0, depth=2.0)
    elif shape == "sphere":
        bmesh.ops.create_uvsphere(bm, u_segments=32, v_segments=16, radius=1.0)
    elif shape == "monkey":
        bmesh.ops.create_monkey(bm)
    elif shape == "plane":
        bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=1.0)
    else:
        raise ValueError(shape)
    smooth = shape in ("sphere", "monkey")
    for f in bm.faces:
        f.smooth = smooth
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    me["ssgi_room"] = True
    return me


def wall_placements(W: float, D: float, H: float) -> dict:
    """{wall: (location, rotation, scale)} of the box's six planes (the grid is 2x2 m, scaled), normals
    pointing into a W x D x H room (both modes)."""
    return {
        "floor": ((0, 0, 0), (0, 0, 0), (W / 2, D / 2, 1)),
        "ceiling": ((0, 0, H), (math.pi, 0, 0), (W / 2, D / 2, 1)),
        "wall_xn": ((-W / 2, 0, H / 2), (0, math.pi / 2, 0), (H / 2, D / 2, 1)),
        "wall_xp": ((W / 2, 0, H / 2), (0, -math.pi / 2, 0), (H / 2, D / 2, 1)),
        "wall_yn": ((0, -D / 2, H / 2), (-math.pi / 2, 0, 0), (W / 2, H / 2, 1)),
        "wall_yp": ((0, D / 2, H / 2), (math.pi / 2, 0, 0), (W / 2, H / 2, 1)),
    }


def add_light(scene, d: dict) -> bpy.types.Object:
    """A lamp of ``room_params``' light dict ``d`` (point, spot or area) linked into ``scene`` (both modes)."""
    li = bpy.data.lights.new(d["name"], d["type"])
    li.color = d["colour"]
    li.energy = d["energy"]
    if d["type"] == "AREA":
        li.shape, li.size, li.size_y = d["shape"], d["size"], d["size_y"]
    else:
        li.shadow_soft_size = d["radius"]
    if d["type"] == "SPOT":
        li.spot_size, li.spot_blend = d["spot_size"], d["spot_blend"]
    o = _link(scene, bpy.data.objects.new(d["name"], li))
    o.location, o.rotation_euler = d["location"], d["rotation"]
    return o


def _link(scene, obj) -> bpy.types.Object:
    obj["ssgi_room"] = True
    scene.collection.objects.link(obj)
    return obj


def clear_room(scene) -> None:
    """Remove the objects, meshes, materials, lights, camera and world a previous ``build_room`` added."""
    if scene.world is not None and scene.world.get("ssgi_room"):
        # detached, so that it is removed below; the next room's world is then always named "ssgi.world"
        scene.world = None
    objs = [o for o in scene.objects if o.get("ssgi_room")]
    data = [o.data for o in objs if o.data is not None]
    bpy.data.batch_remove(objs)
    bpy.data.batch_remove([d for d in data if d.users == 0])
    bpy.data.batch_remove([m for m in bpy.data.materials if m.get("ssgi_room") and m.users == 0])
    bpy.data.batch_remove([m for m in bpy.data.meshes if m.get("ssgi_room") and m.users == 0])
    bpy.data.batch_remove([w for w in bpy.data.worlds if w.get("ssgi_room") and w.users == 0])
    bpy.data.batch_remove([i for i in bpy.data.images if i.get("ssgi_room") and i.users == 0])


def build_room(seed: int, scene=None, mode: str = "diffuse"):
    """Build random room ``seed`` of ``mode`` (room_params) into ``scene`` (a new scene when None; a previous
    room there is replaced)."""
    prm = room_params(seed, mode)
    if scene is None:
        scene = bpy.data.scenes.new(f"SSGI Room {seed}")
    clear_room(scene)
    if mode in ("artist", "studio", "interior"):
        from .room_artist_build import build
        build(prm, scene)
        scene["ssgi_room_seed"], scene["ssgi_room_mode"] = int(seed), mode
        return scene
    if "ssgi_room_mode" in scene:
        del scene["ssgi_room_mode"]
    W, D, H = prm["size"]

    placements = wall_placements(W, D, H)
    for w in WALLS:
        if w == prm["open_side"]:
            continue
        loc, rot, sc = placements[w]
        name = f"{PREFIX}room.{w}"
        me = _mesh("plane", name)
        me.materials.append(diffuse_material(name, prm["surfaces"][w]))
        o = _link(scene, bpy.data.objects.new(name, me))
        o.location, o.rotation_euler, o.scale = loc, rot, sc

    for d in prm["objects"]:
        me = _mesh(d["shape"], d["name"])
        me.materials.append(diffuse_material(d["name"], d["colour"]))
        o = _link(scene, bpy.data.objects.new(d["name"], me))
        o.location, o.rotation_euler, o.scale = d["location"], d["rotation"], d["scale"]

    for d in prm["lights"]:
        add_light(scene, d)

    c = prm["camera"]
    cam = bpy.data.cameras.new(c["name"])
    cam.lens = c["lens"]
    cam.clip_start, cam.clip_end = 0.05, 100.0
    o = _link(scene, bpy.data.objects.new(c["name"], cam))
    o.location, o.rotation_euler = c["location"], c["rotation"]
    scene.camera = o

    # the world: seen (and lighting the room) only through an open side
    world = bpy.data.worlds.new(f"{PREFIX}world")
    world["ssgi_room"] = True
    wt = world.node_tree
    if wt is None:
        world.use_nodes = True
        wt = world.node_tree
    bg = next(n for n in wt.nodes if n.bl_idname == "ShaderNodeBackground")
    strength = prm["world"]["strength"] if prm["open_side"] else 0.0
    bg.inputs["Color"].default_value = (*prm["world"]["colour"], 1.0)
    bg.inputs["Strength"].default_value = strength
    world.color = tuple(x * strength for x in prm["world"]["colour"])
    scene.world = world
    scene.view_settings.view_transform = "Standard"
    scene["ssgi_room_seed"] = int(seed)
    return scene


def describe_scene(scene) -> dict:
    """Names, transforms, colours and light settings of ``scene``'s room objects (for tests and manifests)."""
    out = {}
    artist = scene.get("ssgi_room_mode") in ("artist", "studio", "interior")  # (diffuse rooms: the description they always had)
    for o in sorted(scene.objects, key=lambda o: o.name):
        # matrix_basis, not matrix_world: the latter is stale until the depsgraph is evaluated
        d = dict(type=o.type, location=tuple(round(v, 5) for v in o.location),
                 matrix=[round(v, 5) for row in o.matrix_basis for v in row])
        if o.type == "MESH" and o.data.materials:
            m = o.data.materials[0]
            p = next((n for n in m.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
            if p is not None:
                d["colour"] = tuple(round(v, 5) for v in p.inputs["Base Color"].default_value)
                if artist:
                    d["material"] = {k: round(p.inputs[k].default_value, 5) for k in SHADING}
                    d["material"]["textures"] = sorted(n.bl_idname for n in m.node_tree.nodes
                                                       if n.bl_idname.startswith("ShaderNodeTex"))
        if o.type == "LIGHT":
            li = o.data
            d.update(light=li.type, energy=round(li.energy, 4), colour=tuple(round(v, 5) for v in li.color),
                     radius=round(li.shadow_soft_size, 5))
            if li.type == "AREA":
                d.update(shape=li.shape, size=round(li.size, 5), size_y=round(li.size_y, 5))
            if li.type == "SPOT":
                d.update(spot_size=round(li.spot_size, 5), spot_blend=round(li.spot_blend, 5))
            if li.type == "SUN":
                d.update(angle=round(li.angle, 5))
        if o.type == "CAMERA":
            d["lens"] = round(o.data.lens, 5)
        out[o.name] = d
    return out
