"""Build an artist-mode scene (room_artist.py ``artist_params``) or a studio (room_studio.py ``studio_params``)
with bpy: Principled materials with node textures or generated images, emissive fixtures, walls with windows, a
ground or a cyclorama, Sky/gradient/uniform worlds, a sun.

Every datablock it adds is named with ``PREFIX`` and carries ``ssgi_room`` (room.py ``clear_room`` removes
objects, meshes, materials, lights, cameras, worlds and images so marked).
"""
from __future__ import annotations

import math

import bmesh
import bpy
import numpy as np

from .room_artist import PREFIX


def _tag(idb):
    idb["ssgi_room"] = True
    return idb


def mesh(shape: str, name: str) -> bpy.types.Mesh:
    """Unit meshes (span [-1, 1]): room.py's primitives plus open tubes/shades and a plane with a window."""
    from .room import _mesh
    if shape not in ("tube", "shade"):
        return _mesh(shape, name)
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=False, segments=32, radius1=1.0, radius2=1.0 if shape == "tube" else 0.6,
                          depth=2.0)
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    return _tag(me)


def window_plane(name: str, hole) -> bpy.types.Mesh:
    """The unit plane [-1, 1]^2 less the rectangle ``hole`` = (u0, u1, v0, v1): four quads around it."""
    u0, u1, v0, v1 = hole
    rects = ((-1, u0, -1, 1), (u1, 1, -1, 1), (u0, u1, -1, v0), (u0, u1, v1, 1))
    verts, faces = [], []
    for a, b, c, d in rects:
        k = len(verts)
        verts += [(a, c, 0.0), (b, c, 0.0), (b, d, 0.0), (a, d, 0.0)]
        faces.append((k, k + 1, k + 2, k + 3))
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, [], faces)
    me.update()
    return _tag(me)


def window_hole(wall: str, hole) -> tuple:
    """A window (u0, u1, v0, v1: u along the wall, v up, fractions of the half-extents) in the wall plane's
    local coordinates (placements in ``build``: wall_yn's local y points down, wall_x*'s local x up or down)."""
    u0, u1, v0, v1 = hole
    return {"wall_yp": (u0, u1, v0, v1), "wall_yn": (u0, u1, -v1, -v0),
            "wall_xp": (v0, v1, u0, u1), "wall_xn": (-v1, -v0, u0, u1)}[wall]


def cyclorama_mesh(name: str, c: dict, segments: int = 16) -> bpy.types.Mesh:
    """A studio cyclorama (room_studio.py): a floor from y = front to the cove, a quarter circle of ``radius``
    up to a back wall at y = back, ``height`` tall, ``width`` wide (centred on x = 0); smooth-shaded."""
    r, yb, w = c["radius"], c["back"], c["width"] / 2
    yc = yb - r
    prof = [(c["front"], 0.0), (yc, 0.0)]
    prof += [(yc + r * math.sin(a), r - r * math.cos(a)) for a in (math.pi / 2 * i / segments for i in range(1, segments + 1))]
    prof += [(yb, c["height"])]
    bm = bmesh.new()
    rows = [[bm.verts.new((x, y, z)) for y, z in prof] for x in (-w, w)]
    for i in range(len(prof) - 1):
        bm.faces.new((rows[0][i], rows[1][i], rows[1][i + 1], rows[0][i + 1]))
    me = bpy.data.meshes.new(name)
    bm.to_mesh(me)
    bm.free()
    for poly in me.polygons:
        poly.use_smooth = True
    return _tag(me)


def _image(name: str, t: dict, base, res: int = 128) -> bpy.types.Image:
    """A generated tile image (no file; packed so that a saved .blend keeps it)."""
    rng = np.random.default_rng(t["seed"])
    n = t["tiles"]
    a, b = np.asarray(base, np.float32), np.asarray(t["colour2"], np.float32)
    shades = rng.uniform(0.0, 1.0, (n, n, 1)).astype(np.float32)
    cols = a + (b - a) * shades * 0.7
    cols *= 1.0 + rng.uniform(-t["jitter"], t["jitter"], (n, n, 1)).astype(np.float32)
    y, x = np.mgrid[0:res, 0:res]
    cell = res // n
    if t["pattern"] == "planks":  # rows of boards, every other row shifted by half a board
        row = y // cell
        col = ((x + (row % 2) * cell // 2) // cell) % n
        img = cols[row % n, col]
        grout = (y % cell) < 2
    else:
        img = cols[(y // cell) % n, (x // cell) % n]
        grout = ((y % cell) < (3 if t["pattern"] == "grid" else 1)) | ((x % cell) < (3 if t["pattern"] == "grid" else 1))
    img = np.where(grout[..., None], img * 0.35, img)
    rgba = np.concatenate([np.clip(img, 0, 1), np.ones((res, res, 1), np.float32)], axis=-1)
    im = _tag(bpy.data.images.new(name, res, res))
    im.pixels.foreach_set(rgba.ravel())
    im.pack()
    return im


def _texture(nt, name: str, t: dict, base, scale) -> bpy.types.NodeSocket:
    """Base-colour texture nodes; coordinates in metres on the surface (object coordinates x object scale)."""
    nodes, links = nt.nodes, nt.links
    tc = nodes.new("ShaderNodeTexCoord")
    vm = nodes.new("ShaderNodeVectorMath")
    vm.operation = "MULTIPLY"
    vm.inputs[1].default_value = tuple(scale)
    links.new(tc.outputs["Object"], vm.inputs[0])
    vec = vm.outputs["Vector"]
    c1, c2 = (*base, 1.0), (*t["colour2"], 1.0)
    kind = t["type"]
    if kind == "image":
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = _image(f"{name}.image", t, base)
        tex.projection, tex.projection_blend = "BOX", 0.2
        sv = nodes.new("ShaderNodeVectorMath")
        sv.operation = "SCALE"
        sv.inputs["Scale"].default_value = t["scale"]
        links.new(vec, sv.inputs[0])
        links.new(sv.outputs["Vector"], tex.inputs["Vector"])
        return tex.outputs["Color"]
    tex = nodes.new({"checker": "ShaderNodeTexChecker", "noise": "ShaderNodeTexNoise",
                     "voronoi": "ShaderNodeTexVoronoi", "brick": "ShaderNodeTexBrick",
                     "wave": "ShaderNodeTexWave"}[kind])
    links.new(vec, tex.inputs["Vector"])
    tex.inputs["Scale"].default_value = t["scale"]
    if kind in ("checker", "brick"):
        tex.inputs["Color1"].default_value, tex.inputs["Color2"].default_value = c1, c2
        if kind == "brick":
            tex.inputs["Mortar"].default_value = tuple(0.6 * v for v in c1[:3]) + (1.0,)
            tex.inputs["Mortar Size"].default_value = 0.03
        return tex.outputs["Color"]
    if kind == "wave":
        tex.inputs["Distortion"].default_value = t["distortion"]
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    links.new(tex.outputs["Distance" if kind == "voronoi" else ("Factor" if kind == "noise" else "Color")],
              mix.inputs["Factor"])
    mix.inputs[6].default_value, mix.inputs[7].default_value = c1, c2  # A, B of the RGBA mix
    return mix.outputs[2]


def material(name: str, m: dict, scale=(1.0, 1.0, 1.0)) -> bpy.types.Material:
    """The Principled BSDF of ``m`` (room_artist.material), textured on the base colour when it has one."""
    mat = _tag(bpy.data.materials.new(name))
    nt = mat.node_tree
    if nt is None:
        mat.use_nodes = True
        nt = mat.node_tree
    p = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    inp = p.inputs
    inp["Base Color"].default_value = (*m["base"], 1.0)
    inp["Roughness"].default_value = m["roughness"]
    inp["Specular IOR Level"].default_value = m["specular"]
    inp["Metallic"].default_value = m["metallic"]
    inp["Transmission Weight"].default_value = m["transmission"]
    inp["IOR"].default_value = m["ior"]
    inp["Coat Weight"].default_value = m["coat"]
    if m["emission"] is not None:
        inp["Emission Color"].default_value = (*m["emission"], 1.0)
        inp["Emission Strength"].default_value = m["strength"]
    if m["texture"] is not None:
        nt.links.new(_texture(nt, name, m["texture"], m["base"], scale), inp["Base Color"])
    mat.diffuse_color = (*m["base"], 1.0)
    mat.metallic, mat.roughness = m["metallic"], m["roughness"]
    return mat


def _object(scene, name, me, mat, loc, rot, sc):
    from .room import _link
    me.materials.append(mat)
    o = _link(scene, bpy.data.objects.new(name, me))
    o.location, o.rotation_euler, o.scale = loc, rot, sc
    return o


def _world(scene, prm) -> None:
    w = _tag(bpy.data.worlds.new(f"{PREFIX}world"))
    nt = w.node_tree
    if nt is None:
        w.use_nodes = True
        nt = w.node_tree
    bg = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBackground")
    d = prm["world"]
    nodes, links = nt.nodes, nt.links
    if d["type"] == "black":
        bg.inputs["Color"].default_value, bg.inputs["Strength"].default_value = (0, 0, 0, 1), 0.0
        w.color = (0.0, 0.0, 0.0)
    elif d["type"] == "colour":  # a studio's dim stage (room_studio.py)
        bg.inputs["Color"].default_value, bg.inputs["Strength"].default_value = (*d["colour"], 1.0), d["strength"]
        w.color = tuple(c * d["strength"] for c in d["colour"])
    elif d["type"] == "sky":
        sky = nodes.new("ShaderNodeTexSky")
        sky.sky_type = d["sky"]
        # Nishita-type skies turn the sun clockwise from +Y, _sun_dir (and Hosek-Wilkie) counter-clockwise
        sky.sun_elevation, sky.sun_rotation = d["elevation"], (-d["azimuth"]) % math.tau
        sky.sun_direction = _sun_dir(d["elevation"], d["azimuth"])  # Hosek-Wilkie's sun
        if hasattr(sky, "sun_disc"):
            sky.sun_disc = False  # the Sun light object is the sun (EEVEE shadows it)
        links.new(sky.outputs["Color"], bg.inputs["Color"])
        bg.inputs["Strength"].default_value = d["strength"]
        w.color = (0.4 * d["strength"],) * 3
    else:  # HDRI-like: ground / horizon / zenith gradient over the view direction's z, plus a sun disc
        tc = nodes.new("ShaderNodeTexCoord")
        sep = nodes.new("ShaderNodeSeparateXYZ")
        links.new(tc.outputs["Generated"], sep.inputs[0])
        ramp = nodes.new("ShaderNodeValToRGB")
        mr = nodes.new("ShaderNodeMapRange")
        mr.inputs["From Min"].default_value, mr.inputs["From Max"].default_value = -1.0, 1.0
        links.new(sep.outputs["Z"], mr.inputs["Value"])
        links.new(mr.outputs["Result"], ramp.inputs["Fac"])
        el = ramp.color_ramp.elements
        el[0].position, el[0].color = 0.45, (*d["ground"], 1.0)
        el[1].position, el[1].color = 1.0, (*d["zenith"], 1.0)
        e = el.new(0.5)
        e.color = (*d["horizon"], 1.0)
        sun = _sun_dir(d["elevation"], d["azimuth"])
        dot = nodes.new("ShaderNodeVectorMath")
        dot.operation = "DOT_PRODUCT"
        dot.inputs[1].default_value = sun
        links.new(tc.outputs["Generated"], dot.inputs[0])
        disc = nodes.new("ShaderNodeMapRange")
        disc.inputs["From Min"].default_value = math.cos(d["disc_size"])
        disc.inputs["From Max"].default_value = math.cos(d["disc_size"] * 0.7)
        disc.inputs["To Max"].default_value = d["disc"]
        links.new(dot.outputs["Value"], disc.inputs["Value"])
        add = nodes.new("ShaderNodeMix")
        add.data_type, add.blend_type = "RGBA", "ADD"
        add.inputs["Factor"].default_value = 1.0
        links.new(ramp.outputs["Color"], add.inputs[6])
        rgb = nodes.new("ShaderNodeCombineXYZ")
        for k in "XYZ":
            links.new(disc.outputs["Result"], rgb.inputs[k])
        links.new(rgb.outputs["Vector"], add.inputs[7])
        links.new(add.outputs[2], bg.inputs["Color"])
        bg.inputs["Strength"].default_value = d["strength"]
        w.color = tuple(c * d["strength"] for c in d["horizon"])
    scene.world = w


def _sun_dir(elevation: float, azimuth: float) -> tuple:
    """Unit vector toward the sun; azimuth 0: toward +Y, counter-clockwise seen from above (Hosek-Wilkie's
    sun_direction; Nishita-type skies take sun_rotation = -azimuth, measured)."""
    return (-math.sin(azimuth) * math.cos(elevation), math.cos(azimuth) * math.cos(elevation), math.sin(elevation))


def build(prm: dict, scene) -> None:
    """Add the scene of ``prm`` (artist_params) to ``scene`` (room.py build_room cleared it first)."""
    from .room import _link, add_light, wall_placements
    W, D, H = prm["size"]
    if prm["kind"] == "exterior":
        _object(scene, f"{PREFIX}ground", mesh("plane", f"{PREFIX}ground"),
                material(f"{PREFIX}ground", prm["ground"], (W / 2, D / 2, 1.0)), (0, 0, 0), (0, 0, 0),
                (W / 2, D / 2, 1.0))
    if prm.get("cyclorama"):
        c = prm["cyclorama"]
        _object(scene, c["name"], cyclorama_mesh(c["name"], c), material(c["name"], c["material"]),
                (0, 0, 0), (0, 0, 0), (1, 1, 1))
    placements = wall_placements(W, D, H)
    for w, d in prm["walls"].items():
        name = f"{PREFIX}room.{w}"
        loc, rot, sc = placements[w]
        hole = d["window"]
        if hole is not None:
            hole = window_hole(w, hole)
        me = window_plane(name, hole) if hole is not None else mesh("plane", name)
        _object(scene, name, me, material(name, d["material"], sc), loc, rot, sc)
    for d in prm["objects"] + prm["emitters"]:
        _object(scene, d["name"], mesh(d["shape"], d["name"]), material(d["name"], d["material"], d["scale"]),
                d["location"], d["rotation"], d["scale"])
    for d in prm["lights"]:
        _tag(add_light(scene, d).data)
    if prm["sun"] is not None:
        s = prm["sun"]
        li = _tag(bpy.data.lights.new(f"{PREFIX}light.sun", "SUN"))
        li.energy, li.angle, li.color = s["energy"], s["angle"], s["colour"]
        o = _link(scene, bpy.data.objects.new(f"{PREFIX}light.sun", li))
        x, y, z = _sun_dir(s["elevation"], s["azimuth"])
        # a sun shines along its -Z: point -Z away from the sun
        o.rotation_euler = (math.atan2(math.hypot(x, y), z), 0.0, math.atan2(y, x) + math.pi / 2)
    c = prm["camera"]
    cam = _tag(bpy.data.cameras.new(c["name"]))
    cam.lens = c["lens"]
    cam.clip_start, cam.clip_end = 0.05, 200.0
    o = _link(scene, bpy.data.objects.new(c["name"], cam))
    o.location, o.rotation_euler = c["location"], c["rotation"]
    scene.camera = o
    _world(scene, prm)
    scene.view_settings.view_transform = "Standard"
