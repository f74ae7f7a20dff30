"""Direct light beyond the hard-shadow G-buffer (ssgi_addon/blender/direct_light.py) on real bpy, EEVEE and
Cycles at tiny sizes, in subprocesses: the soft direct pass has a penumbra where the hard one has a sharp edge,
and the emitter direct pass lights a floor under an emissive panel where EEVEE's direct pass is black (and
adds nothing where only lamps light)."""
from __future__ import annotations

import json
import textwrap

import numpy as np

from ..conftest import run_py

# a floor, and bpy helpers the two scenes share (run inside the subprocess)
_SCENE = """
import json, math, bpy
import numpy as np
from mathutils import Vector
from ssgi.ssgi_addon.blender import direct_light as dl, passes, room
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.world = bpy.data.worlds.new("w"); scene.world.color = (0, 0, 0)

def plane(name, size, z, down=False, material=None):
    o = bpy.data.objects.new(name, room._mesh("plane", name))
    o.data.materials.append(material or room.diffuse_material(name, (0.8, 0.8, 0.8)))
    o.location, o.scale = (0, 0, z), (size / 2, size / 2, 1)
    o.rotation_euler = (math.pi if down else 0, 0, 0)
    scene.collection.objects.link(o)
    return o

def camera(loc, target, ortho=None):
    cam = bpy.data.cameras.new("cam")
    if ortho:
        cam.type, cam.ortho_scale = "ORTHO", ortho
    o = bpy.data.objects.new("cam", cam)
    o.location = loc
    o.rotation_euler = (Vector(target) - Vector(loc)).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(o)
    scene.camera = o

plane("floor", 6.0, 0.0)
"""


def _edge_width(row, unshadowed):
    """Pixels where ``row`` is between 10 % and 90 % of the light without the occluder (the shadow edge)."""
    v = row / unshadowed
    return int(((v > 0.1) & (v < 0.9)).sum())


def test_soft_direct_has_a_penumbra_where_hard_direct_has_a_sharp_edge():
    # a 1.2 m area light 2.4 m up and 2 m to the side, a 1 m plate 0.8 m above the floor: its shadow on the
    # floor spans x = 0.25..1.75 m beside the plate, umbra 0.55..1.45, each penumbra 1.2 * 0.8 / 1.6 = 0.6 m
    # (~9 px at 64 px over 4.4 m; orthographic camera looking down)
    code = _SCENE + textwrap.dedent("""
    plate = plane("plate", 1.0, 0.8)
    li = bpy.data.lights.new("area", "AREA"); li.size = 1.2; li.energy = 300
    o = bpy.data.objects.new("area", li); o.location = (-2.0, 0, 2.4); scene.collection.objects.link(o)
    camera((0.6, 0, 5), (0.6, 0, 0), ortho=4.4)
    passes.set_resolution(scene, 64, 64)
    hard = passes.render_gbuffer(scene, ("direct",), keep_sky=False)["direct"][..., :3]
    soft = dl.render_soft_direct(scene)
    cyc = dl.render_cycles_direct(scene, 256)
    cyc_hard = dl.render_cycles_direct(scene, 64, hard=True)
    no_emitters = dl.render_emitter_direct(scene, 1)  # lamps hidden: nothing here emits
    print("EMITTERS", float(no_emitters.max()))
    plate.hide_render = True  # the light without the shadow, to divide by
    imgs = dict(hard=hard, soft=soft, cycles=cyc, cycles_hard=cyc_hard,
                open=dl.render_cycles_direct(scene, 64), open_hard=dl.render_cycles_direct(scene, 64, hard=True))
    print("JSON" + json.dumps({k: v[32, :, 1].tolist() for k, v in imgs.items()}))
    """)
    out = run_py(code).stdout
    # adds nothing to the lamps' soft direct (OIDN of a black image: 4e-6, measured)
    assert float(out.split("EMITTERS", 1)[1].split()[0]) < 1e-4
    rows = {k: np.array(v) for k, v in json.loads(out.split("JSON", 1)[1]).items()}
    # each EEVEE row against Cycles with the same light size: the same light and shadow, up to EEVEE's
    # approximate penumbra (13 % of the peak at most, measured)
    for k, ref in (("hard", "cycles_hard"), ("soft", "cycles")):
        err = np.abs(rows[k] - rows[ref]) / rows[ref].max()
        assert err.mean() < 0.03 and err.max() < 0.2, (k, err.mean(), err.max())
    hard, soft, cyc = (_edge_width(rows[k], rows[o]) for k, o in (("hard", "open_hard"), ("soft", "open"), ("cycles", "open")))
    assert hard <= 4, rows["hard"]  # a sharp edge on each side: 1-2 px each
    assert soft >= 8 and cyc >= 8, (soft, cyc)  # both edges, each ~7 px from 10 to 90 %: the penumbra
    assert abs(soft - cyc) <= 6, (soft, cyc)  # as wide as Cycles' penumbra
    # the umbra (x = 1 m, pixel 38) stays dark in both
    assert rows["soft"][38] < 0.1 * rows["open"][38] and rows["hard"][38] < 0.05 * rows["open_hard"][38]


def test_emitter_direct_lights_the_floor_under_an_emissive_panel_where_eevee_direct_is_black():
    code = _SCENE + textwrap.dedent("""
    m = bpy.data.materials.new("emit"); nt = m.node_tree; nt.nodes.clear()
    em = nt.nodes.new("ShaderNodeEmission"); em.inputs["Strength"].default_value = 20.0
    out = nt.nodes.new("ShaderNodeOutputMaterial"); nt.links.new(em.outputs[0], out.inputs["Surface"])
    plane("panel", 1.0, 1.0, down=True, material=m)
    camera((0, -3.0, 2.5), (0, 0, 0))
    passes.set_resolution(scene, 64, 36)
    hard = passes.render_gbuffer(scene, ("direct",), keep_sky=False)["direct"][..., :3]
    emitter = dl.render_emitter_direct(scene)
    cyc = dl.render_cycles_direct(scene, 512, seed=7)
    rows = slice(24, 34)  # the floor in front of and under the panel
    print("JSON" + json.dumps({k: float(v[rows].mean()) for k, v in dict(hard=hard, emitter=emitter, cycles=cyc).items()}))
    """)
    m = json.loads(run_py(code).stdout.split("JSON", 1)[1])
    assert m["cycles"] > 0.2, m  # the panel lights the floor (converged Cycles)
    assert m["hard"] < 1e-3, m  # EEVEE's direct pass: black
    assert abs(m["emitter"] / m["cycles"] - 1) < 0.15, m  # the few-sample denoised pass: Cycles' level
