"""Benchmark scenes for docs/fit.md: a Cornell-box-style room with a short camera move.

    .venv/bin/python benchmarks/fit_scenes.py cornell OUT.blend

(The cluttered random room comes from `cli.py randomize --seed N --save F.blend`.)
"""
import math
import sys
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import bpy  # noqa: E402


def diffuse(name, rgb):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*rgb, 1.0)
    o = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(d.outputs[0], o.inputs[0])
    return m


def plane(name, loc, rot, size, mat):
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
    o = bpy.context.object
    o.name = name
    o.data.materials.append(mat)
    return o


def box(name, loc, dims, rot_z, mat):
    bpy.ops.mesh.primitive_cube_add(size=1, location=loc, rotation=(0, 0, rot_z))
    o = bpy.context.object
    o.name = name
    o.scale = dims
    o.data.materials.append(mat)
    return o


def cornell(out: str) -> None:
    sc = _bootstrap.empty_scene()
    white, red, green = diffuse("white", (0.73, 0.73, 0.73)), diffuse("red", (0.65, 0.05, 0.05)), diffuse("green", (0.12, 0.45, 0.15))
    h = math.pi / 2
    plane("floor", (0, 0, 0), (0, 0, 0), 2, white)
    plane("ceiling", (0, 0, 2), (math.pi, 0, 0), 2, white)
    plane("back", (0, 1, 1), (h, 0, 0), 2, white)
    plane("left", (-1, 0, 1), (0, h, 0), 2, red)
    plane("right", (1, 0, 1), (0, -h, 0), 2, green)
    box("tall", (-0.33, 0.3, 0.6), (0.6, 0.6, 1.2), math.radians(17), white)
    box("short", (0.35, -0.25, 0.3), (0.6, 0.6, 0.6), math.radians(-17), white)
    bpy.ops.object.light_add(type="AREA", location=(0, 0, 1.98))
    li = bpy.context.object
    li.data.size = 0.5
    li.data.energy = 60
    bpy.ops.object.camera_add(location=(0, -3.6, 1.0), rotation=(h, 0, 0))
    cam = bpy.context.object
    cam.data.lens = 35
    sc.camera = cam
    for f, x, y in ((1, -0.15, -3.6), (48, 0.15, -3.3)):  # a slow dolly in, slightly sideways
        cam.location = (x, y, 1.0)
        cam.keyframe_insert("location", frame=f)
    sc.frame_start, sc.frame_end = 1, 48
    sc.frame_set(1)
    world = bpy.data.worlds.new("World")
    world.color = (0.0, 0.0, 0.0)
    # a new world in 5.0 has a node tree whose Background is 0.05 grey: the colour alone left the sky lit
    for n in (world.node_tree.nodes if world.node_tree else ()):
        if n.bl_idname == "ShaderNodeBackground":
            n.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
            n.inputs["Strength"].default_value = 0.0
    sc.world = world
    sc.render.resolution_x, sc.render.resolution_y = 1920, 1080
    bpy.ops.wm.save_as_mainfile(filepath=str(Path(out).resolve()))


if __name__ == "__main__":
    {"cornell": cornell}[sys.argv[1]](sys.argv[2])
