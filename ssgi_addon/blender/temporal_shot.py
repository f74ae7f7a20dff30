"""The default shot of the temporal measure, built in code: 24 frames of a camera that dollies and pans
through an open-front room while a cube crosses it and the floor ripples (a Wave modifier: a deforming mesh).
The report (``cli.py report --shot`` without a file) and benchmarks/temporal.py use it; a shot .blend of one's
own replaces it."""
from __future__ import annotations

import math

import bpy


def linear_keys(obj) -> None:
    """Every keyframe of ``obj``'s action linear (a steady move)."""
    for lay in obj.animation_data.action.layers:
        for st in lay.strips:
            for cb in st.channelbags:
                for fc in cb.fcurves:
                    for k in fc.keyframe_points:
                        k.interpolation = "LINEAR"


def diffuse_material(name: str, rgb):
    """A rough diffuse Principled material of colour ``rgb``."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rgb, 1)
    bsdf.inputs["Roughness"].default_value = 1.0
    return m


def wavy_floor(rgb, levels: int, height: float, width: float, speed: float, size: float = 8.0):
    """A floor plane subdivided ``levels`` times with a Wave modifier (a deforming mesh; speed 0: still)."""
    bpy.ops.mesh.primitive_plane_add(size=size)
    floor = bpy.context.object
    floor.data.materials.append(diffuse_material("floor", rgb))
    sub = floor.modifiers.new("sub", "SUBSURF")
    sub.subdivision_type, sub.levels, sub.render_levels = "SIMPLE", levels, levels
    wave = floor.modifiers.new("wave", "WAVE")
    wave.height, wave.width, wave.speed = height, width, speed
    return floor


def point_lamp(scene, energy: float, radius: float, location):
    """A point lamp object linked into ``scene``."""
    li = bpy.data.lights.new("lamp", "POINT")
    li.energy, li.shadow_soft_size = energy, radius
    lo = bpy.data.objects.new("lamp", li)
    lo.location = location
    scene.collection.objects.link(lo)
    return lo


def build_shot(size=(160, 90), frames: int = 24, samples: int = 8):
    """The default shot: an open-front room (floor with a Wave ripple, back and side walls), a red cube that
    crosses it, a point lamp; the camera dollies 1.4 m sideways and 0.6 m in while panning 10 degrees.
    EEVEE at ``samples`` with ray tracing and fast GI (its own GI)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.resolution_x, sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.frame_start, sc.frame_end = 1, frames
    sc.eevee.taa_render_samples = samples
    sc.eevee.use_raytracing = True
    sc.eevee.use_fast_gi = True
    wavy_floor((0.8, 0.7, 0.5), 6, 0.12, 1.2, 0.15)
    for name, loc, rot, rgb in (("back", (0, 3, 2), (math.radians(90), 0, 0), (0.3, 0.5, 0.8)),
                                ("left", (-3.5, 0, 2), (0, math.radians(90), 0), (0.8, 0.8, 0.8)),
                                ("right", (3.5, 0, 2), (0, math.radians(90), 0), (0.2, 0.7, 0.3))):
        bpy.ops.mesh.primitive_plane_add(size=8, location=loc, rotation=rot)
        bpy.context.object.data.materials.append(diffuse_material(name, rgb))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-1.5, 0.5, 0.6))
    cube = bpy.context.object
    cube.data.materials.append(diffuse_material("cube", (0.9, 0.2, 0.1)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(1.2, 1.2, 0.6))
    bpy.context.object.data.materials.append(diffuse_material("sphere", (0.9, 0.9, 0.9)))
    point_lamp(sc, 600, 0.15, (1.5, -1.0, 3.5))
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.location, cam.rotation_euler = (-0.7, -6.5, 2.6), (math.radians(72), 0, math.radians(-5))
    cam.keyframe_insert("location", frame=1)
    cam.keyframe_insert("rotation_euler", frame=1)
    cam.location, cam.rotation_euler = (0.7, -5.9, 2.6), (math.radians(72), 0, math.radians(5))
    cam.keyframe_insert("location", frame=frames)
    cam.keyframe_insert("rotation_euler", frame=frames)
    cube.keyframe_insert("location", frame=1)
    cube.location = (1.3, -0.6, 0.6)
    cube.keyframe_insert("location", frame=frames)
    for o in (cam, cube):
        linear_keys(o)
    w = bpy.data.worlds.new("sky")
    w.color = (0.0, 0.0, 0.0)
    sc.world = w
    return sc
