"""Scenes as a new user makes them: Blender's factory settings (EEVEE as a new file has it: ray tracing off, 64
render samples, the factory world or none), with the surfaces EEVEE renders without diffuse light: a clear glass
object, a mirror metal, an emissive panel and the world seen directly.

``build(kind, size)`` resets Blender (``read_factory_settings``) and builds scene ``kind``:

- ``"empty"``: an empty factory file (``use_empty=True``; it has no world, ``scene.world`` None) with a floor, a
  back wall, a point light, an emissive panel, a mirror sphere (Principled, metallic 1, roughness 0), a clear glass
  cube (the Glass BSDF node, roughness 0), a rough Principled glass sphere (transmission 1, roughness 0.3) and a
  rough gold sphere (metallic 1, roughness 0.3). Without a world and without ray tracing, EEVEE shows the clear glass
  and the mirror black (they show only the world), the rough ones with the lamp's highlight.
- ``"startup"``: Blender's default startup file (``use_empty=False``: the default cube, light, camera and grey
  world) with a clear glass sphere (Glass BSDF) and a mirror sphere beside the cube, seen by the default camera.

Only the resolution is set (the file's 100 % at ``size``); every render setting stays the factory's.
``masks(scene)`` gives each role's pixels (a camera ray through each pixel centre, ``Scene.ray_cast``), and
``world`` where no ray hits.
"""
from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

KINDS = ("empty", "startup")


def _material(name: str, node: str = "ShaderNodeBsdfPrincipled", **inputs):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        if n.bl_idname != "ShaderNodeOutputMaterial":
            nt.nodes.remove(n)
    out = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    bsdf = nt.nodes.new(node)
    for k, v in inputs.items():
        bsdf.inputs[k].default_value = v
    nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return m


def _object(op, name: str, material, **kw):
    op(**kw)
    o = bpy.context.object
    o.name = name
    o.data.materials.append(material)
    return o


def _empty(scene) -> dict[str, str]:
    mesh = bpy.ops.mesh
    _object(mesh.primitive_plane_add, "factory_floor",
            _material("factory_floor", **{"Base Color": (0.6, 0.6, 0.6, 1.0)}), size=10)
    _object(mesh.primitive_plane_add, "factory_wall", _material("factory_wall", **{"Base Color": (0.7, 0.5, 0.4, 1.0)}),
            size=10, location=(0, 4, 0), rotation=(math.pi / 2, 0, 0))
    panel = _object(mesh.primitive_plane_add, "factory_emissive",
                    _material("factory_emission", **{"Base Color": (0.0, 0.0, 0.0, 1.0),
                                                     "Emission Color": (1.0, 0.8, 0.6, 1.0), "Emission Strength": 8.0}),
                    size=1.0, location=(0, 3.9, 2.0), rotation=(math.pi / 2, 0, 0))
    metal = _object(mesh.primitive_uv_sphere_add, "factory_metal",
                    _material("factory_mirror", **{"Base Color": (0.9, 0.9, 0.9, 1.0), "Metallic": 1.0,
                                                   "Roughness": 0.0}),
                    radius=0.6, location=(-1.5, 0.5, 0.6))
    glass = _object(mesh.primitive_cube_add, "factory_glass",
                    _material("factory_glass", "ShaderNodeBsdfGlass", **{"Roughness": 0.0, "IOR": 1.45}),
                    size=1.1, location=(0.1, 0.3, 0.55))
    rough_glass = _object(mesh.primitive_uv_sphere_add, "factory_rough_glass",
                          _material("factory_rough_glass", **{"Base Color": (1.0, 1.0, 1.0, 1.0),
                                                              "Transmission Weight": 1.0, "Roughness": 0.3,
                                                              "IOR": 1.45}),
                          radius=0.55, location=(1.6, 0.4, 0.55))
    rough_metal = _object(mesh.primitive_uv_sphere_add, "factory_rough_metal",
                          _material("factory_rough_metal", **{"Base Color": (0.95, 0.7, 0.3, 1.0), "Metallic": 1.0,
                                                              "Roughness": 0.3}),
                          radius=0.35, location=(-0.9, -1.0, 0.35))
    bpy.ops.object.light_add(type="POINT", location=(0, -1, 3))
    bpy.context.object.data.energy = 300.0
    bpy.ops.object.camera_add(location=(0, -6, 2.2), rotation=(math.radians(77.5), 0, 0))
    scene.camera = bpy.context.object
    return {"glass": glass.name, "rough_glass": rough_glass.name, "metal": metal.name, "rough_metal": rough_metal.name,
            "emissive": panel.name}


def _startup(scene) -> dict[str, str]:
    glass = _object(bpy.ops.mesh.primitive_uv_sphere_add, "factory_glass",
                    _material("factory_glass", "ShaderNodeBsdfGlass", **{"Roughness": 0.0, "IOR": 1.45}),
                    radius=0.8, location=(1.0, -2.2, 0.0))
    metal = _object(bpy.ops.mesh.primitive_uv_sphere_add, "factory_metal",
                    _material("factory_mirror", **{"Base Color": (0.9, 0.9, 0.9, 1.0), "Metallic": 1.0,
                                                   "Roughness": 0.0}),
                    radius=0.8, location=(1.7, 1.8, 0.0))
    return {"glass": glass.name, "metal": metal.name, "cube": "Cube"}


def build(kind: str, size=(96, 64)):
    """Blender reset to factory settings and scene ``kind`` (KINDS) built in it at ``size``: (scene, {role: object
    name})."""
    if kind not in KINDS:
        raise ValueError(f"{kind!r}: one of {KINDS}")
    bpy.ops.wm.read_factory_settings(use_empty=kind == "empty")
    scene = bpy.context.scene
    names = (_empty if kind == "empty" else _startup)(scene)
    r = scene.render
    r.resolution_x, r.resolution_y = int(size[0]), int(size[1])
    r.resolution_percentage = 100
    scene.view_layers[0].update()
    return scene, names


def masks(scene, names: dict[str, str], erode: int = 1) -> dict[str, np.ndarray]:
    """{role: HxW bool, top row first}: the pixels whose centre sees that role's object, and ``world`` those that see
    nothing, each shrunk by ``erode`` pixels (anti-aliased edges mix two surfaces)."""
    w = scene.render.resolution_x * scene.render.resolution_percentage // 100
    h = scene.render.resolution_y * scene.render.resolution_percentage // 100
    cam = scene.camera
    dg = bpy.context.evaluated_depsgraph_get()
    # the corners of the camera's frame in world space: top-right, bottom-right, bottom-left, top-left
    tr, br, bl, tl = [cam.matrix_world @ v for v in cam.data.view_frame(scene=scene)]
    origin = cam.matrix_world.translation
    hit_by = np.full((h, w), "", dtype=object)
    for y in range(h):
        fy = (y + 0.5) / h
        left, right = tl.lerp(bl, fy), tr.lerp(br, fy)
        for x in range(w):
            p = left.lerp(right, (x + 0.5) / w)
            hit, _loc, _n, _i, obj, _m = scene.ray_cast(dg, origin, (p - origin).normalized())
            hit_by[y, x] = obj.original.name if hit else ""
    out = {role: hit_by == name for role, name in names.items()}
    out["world"] = hit_by == ""
    if erode:
        for role, m in out.items():
            for _ in range(erode):
                m = m & np.roll(m, 1, 0) & np.roll(m, -1, 0) & np.roll(m, 1, 1) & np.roll(m, -1, 1)
            out[role] = m
    return out
