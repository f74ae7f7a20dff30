"""Emitter proxies for emissive meshes that are not planar (direct_light.emitter_proxies(shapes="all"): an orb, a neon
tube), on real Blender at 64x36: a grey floor under a black world, lit only by an emissive sphere and an emissive
tube, both on screen. EEVEE's GI-off render lights the floor with part of their light only (about 60 % of Cycles'
here); with sphere lights standing in (one for the orb, a row along the tube) the floor under each comes within
25 % of Cycles' light there, in its colour, and nothing is left in the scene after the render."""
from __future__ import annotations

import json
import math

import numpy as np

from ..conftest import run_py

CODE = r'''
import json
import math
import numpy as np
import bpy
from ssgi.ssgi_addon.blender import passes, direct_light

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 36, 100
sc.eevee.taa_render_samples = 16
w = bpy.data.worlds.new("black")
w.color = (0.0, 0.0, 0.0)
sc.world = w

def material(name, colour, strength=0.0, emission=(0, 0, 0)):
    m = bpy.data.materials.new(name)
    b = m.node_tree.nodes["Principled BSDF"]
    b.inputs["Base Color"].default_value = (*colour, 1)
    b.inputs["Roughness"].default_value = 1.0
    b.inputs["Specular IOR Level"].default_value = 0.0
    b.inputs["Emission Color"].default_value = (*emission, 1)
    b.inputs["Emission Strength"].default_value = strength
    return m

bpy.ops.mesh.primitive_plane_add(size=6.0, location=(0, 0, 0))
floor = bpy.context.object
floor.data.materials.append(material("floor", (0.5, 0.5, 0.5)))
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.15, location=(-0.8, 0, 0.5), segments=32, ring_count=16)
orb = bpy.context.object
orb.name = "orb"
orb.data.materials.append(material("orb", (0, 0, 0), 20.0, (1.0, 0.6, 0.3)))
bpy.ops.mesh.primitive_cylinder_add(radius=0.02, depth=1.2, location=(0.8, 0, 0.3), rotation=(math.pi / 2, 0, 0))
tube = bpy.context.object
tube.name = "tube"
tube.data.materials.append(material("tube", (0, 0, 0), 60.0, (0.3, 1.0, 0.4)))
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
sc.collection.objects.link(cam)
cam.location = (0, -3.2, 3.0)
cam.rotation_euler = (math.radians(47), 0, 0)
sc.camera = cam
bpy.context.view_layer.update()

res = {"planar": [o.name for o, *_ in direct_light.planar_emitters(sc)],
       "solid": sorted(o.name for o, *_ in direct_light.solid_emitters(sc))}
n_lights, n_objects = len(bpy.data.lights), len(bpy.data.objects)
with direct_light.emitter_proxies(sc, shadows=False, sides="open", shapes="all") as made:
    res["proxies"] = sorted((o.name, o.data.type, o.data.energy, o.data.shadow_soft_size, list(o.location))
                            for o in made)
res["left_behind"] = [len(bpy.data.lights) - n_lights, len(bpy.data.objects) - n_objects]
imgs = {}
for shapes in ("planar", "all"):
    g = passes.render_gbuffer(sc, ("eevee_combined", "albedo", "depth", "normal"), samples=1, rest_samples=16,
                              proxy_shapes=shapes)
    imgs[shapes] = g["eevee_combined"][..., :3]
res["left_behind_render"] = [len(bpy.data.lights) - n_lights, len(bpy.data.objects) - n_objects]
ref = passes.render_cycles(sc, 128, seed=1, denoise=True, groups=("ref",))["ref"][..., :3]
emit = np.zeros(ref.shape[:2], bool)
emit |= g["albedo"].max(-1) < 0.01  # the emitters themselves (albedo 0)
res["floor"] = {}
for side, cols in (("orb", slice(0, 32)), ("tube", slice(32, 64))):
    m = np.zeros(ref.shape[:2], bool)
    m[:, cols] = True
    m &= ~emit
    res["floor"][side] = {k: [float(v) for v in im[m].mean(0)] for k, im in (("planar", imgs["planar"]),
                                                                           ("all", imgs["all"]), ("cycles", ref))}
print("RESULT", json.dumps(res))
'''


def test_sphere_lights_stand_in_for_an_orb_and_a_tube_and_light_the_floor_as_cycles_does():
    p = run_py(CODE, timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["planar"] == [] and res["solid"] == ["orb", "tube"], res
    assert res["left_behind"] == [0, 0] and res["left_behind_render"] == [0, 0], res
    orb = [p for p in res["proxies"] if "_orb" in p[0]]
    tube = [p for p in res["proxies"] if "_tube" in p[0]]
    # the orb: one sphere light at its centre, power pi x strength x area (a closed mesh: 4 pi r^2 within the
    # UV sphere's faceting)
    assert len(orb) == 1 and orb[0][1] == "POINT", orb
    assert abs(orb[0][2] / (math.pi * 20 * 4 * math.pi * 0.15 ** 2) - 1) < 0.03, orb
    assert max(abs(a - b) for a, b in zip(orb[0][4], (-0.8, 0, 0.5))) < 1e-4, orb
    # the tube (1.2 m long, 4 cm thick): a row of sphere lights along it, their powers adding up to the tube's
    assert len(tube) == 8 and {t[1] for t in tube} == {"POINT"}, tube
    area = 2 * math.pi * 0.02 * 1.2 + 2 * math.pi * 0.02 ** 2
    assert abs(sum(t[2] for t in tube) / (math.pi * 60 * area) - 1) < 0.03, tube
    ys = sorted(t[4][1] for t in tube)
    assert abs(ys[0] + 0.525) < 1e-3 and abs(ys[-1] - 0.525) < 1e-3, ys  # spread over its length
    for side in ("orb", "tube"):
        f = res["floor"][side]
        cyc = sum(f["cycles"])
        assert cyc > 0.01, f
        assert sum(f["planar"]) < 0.8 * cyc, f  # without a stand-in EEVEE's GI-off render misses much of it
        # with one, within the stand-in's approximation of the shape and EEVEE's 16 samples of Cycles' light
        assert 0.75 < sum(f["all"]) / cyc < 1.25, f
        # ... and of its colour (orange orb, green tube)
        assert np.argmax(f["all"]) == np.argmax(f["cycles"]), f
