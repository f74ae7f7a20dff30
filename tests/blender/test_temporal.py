"""The temporal mode of the render path, on real EEVEE renders (64x36, 1 sample, the shipped model).

A tiny moving scene made here (camera keyframed, a cube keyframed, a floor with a Wave modifier): the mode on
and off differ; out-of-order frames and a killed-then-resumed `cli.py render` give the in-order frames bit for
bit. A still scene with a camera cut (a timeline marker bound to a second camera): every frame equals the mode
off bit for bit. And EEVEE's Vector pass follows the convention model/infer/temporal.py documents."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np

from ..conftest import ROOT, run_cli, run_py

SCENE = r'''
import math, sys
import bpy

from ssgi.ssgi_addon.blender.temporal_shot import (diffuse_material as mat, linear_keys as linear, point_lamp,
                                                   wavy_floor)

def build(still=False, cut_at=None, last=3):
    """The moving scene over frames 1..last (the cube and the camera keyed at 1 and at ``last``)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 36, 100
    sc.frame_start, sc.frame_end = 1, last
    sc.eevee.taa_render_samples = 1
    wavy_floor((0.8, 0.7, 0.5), 5, 0.15, 1.0, 0.0 if still else 0.25)
    bpy.ops.mesh.primitive_plane_add(size=8, location=(0, 3, 2), rotation=(math.radians(90), 0, 0))
    bpy.context.object.data.materials.append(mat("wall", (0.3, 0.5, 0.8)))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-1, 0, 0.6))
    cube = bpy.context.object
    cube.data.materials.append(mat("cube", (0.9, 0.2, 0.1)))
    point_lamp(sc, 800, 0.2, (2, -2, 4))
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.location, cam.rotation_euler = (-0.6, -6, 3), (math.radians(70), 0, 0)
    if not still:
        for obj, end in ((cube, (1.0, 0.3, 0.6)), (cam, (0.6, -5.6, 3))):
            obj.keyframe_insert("location", frame=1)
            obj.location = end
            obj.keyframe_insert("location", frame=last)
            linear(obj)
    if cut_at is not None:
        cam2 = bpy.data.objects.new("cam2", cam.data)
        sc.collection.objects.link(cam2)
        cam2.location, cam2.rotation_euler = (3, -5, 3), (math.radians(70), 0, math.radians(30))
        sc.timeline_markers.new("A", frame=1).camera = cam
        sc.timeline_markers.new("B", frame=cut_at).camera = cam2
    return sc
'''


def _read_exr(path) -> np.ndarray:
    import OpenEXR
    with OpenEXR.File(str(path), separate_channels=True) as f:
        ch = f.parts[0].channels
        return np.stack([np.asarray(ch[c].pixels, np.float32) for c in "RGB"], -1)


def test_vector_pass_convention_and_moving_scene_temporal_on_off_out_of_order_and_resume(tmp_path):
    blend = tmp_path / "shot.blend"
    code = SCENE + f'''
from ssgi.ssgi_addon.blender import passes
from ssgi.ssgi_addon.blender.compositor import setup_scene
import json, numpy as np
# the convention: an orthographic camera panning +1 m right and +0.5 m up per frame over 8 m and 64 px
sc = build(still=True)
cam = sc.camera
cam.data.type, cam.data.ortho_scale = "ORTHO", 8.0
cam.location, cam.rotation_euler = (0, 0, 10), (0, 0, 0)
for f, (x, y) in ((1, (0, 0)), (2, (1, 0.5)), (3, (4, -1))):
    cam.location = (x, y, 10)
    cam.keyframe_insert("location", frame=f)
linear(cam)
sc.frame_set(2)
g = passes.render_gbuffer(sc, ("depth", "vector"))
v = g["vector"]
print("RESULT", json.dumps([float(np.median(v[..., i])) for i in range(4)]))
sc = build()
setup_scene(sc, None)
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
'''
    p = run_py(code, timeout=600)
    vec = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    # previous position minus now: +8 px right, +4 px up; now minus next: the next step is (+3, -1.5) m
    assert np.allclose(vec, [8, 4, 24, -12], atol=0.05), vec

    def render(out, frames, mode="on", check=True):
        return run_cli("render", "--blend", str(blend), "--out", str(out / "f_####.exr"), "--frames", frames,
                       "--temporal", mode, "--json", timeout=600, check=check)

    a, o, off, b = (tmp_path / n for n in ("inorder", "ooo", "off", "killed"))
    summ = json.loads(render(a, "1-3").stdout)
    assert summ["temporal"] and [r["history_frames"] for r in summ["per_frame"]] == [[], [1], [2, 1]]
    assert not (a / ".ssgi_history").exists()  # a finished run leaves no history behind
    frames = {f: _read_exr(a / f"f_{f:04d}.exr") for f in (1, 2, 3)}
    render(off, "3", mode="off")
    stateless3 = _read_exr(off / "f_0003.exr")
    assert np.abs(frames[3] - stateless3).mean() > 1e-3  # on and off differ on a moving scene
    summ = json.loads(render(o, "3,1").stdout)
    assert summ["per_frame"][0]["history_rendered"] == [2, 1]
    for f in (3, 1):
        assert np.array_equal(_read_exr(o / f"f_{f:04d}.exr"), frames[f]), f"out of order: frame {f} differs"
    # killed after frame 1 (SIGKILL: no clean-up), then the missing frames rendered: the same frames
    env = dict(os.environ, PYTHONHASHSEED="0")
    proc = subprocess.Popen([sys.executable, str(ROOT / "cli.py"), "render", "--blend", str(blend), "--out",
                             str(b / "f_####.exr"), "--frames", "1-3", "--temporal", "on"], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    t0 = time.time()
    while not (b / "f_0001.exr").exists() and proc.poll() is None and time.time() - t0 < 400:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert (b / ".ssgi_history").is_dir()  # the killed run's history stays for the resume
    missing = [f for f in (1, 2, 3) if not (b / f"f_{f:04d}.exr").exists()]
    assert 3 in missing
    summ = json.loads(render(b, ",".join(map(str, missing))).stdout)
    assert 1 not in sum((r.get("history_rendered", []) for r in summ["per_frame"]), [])  # read from the cache
    for f in (1, 2, 3):
        assert np.array_equal(_read_exr(b / f"f_{f:04d}.exr"), frames[f]), f"resumed: frame {f} differs"


def test_a_still_scene_and_a_camera_cut_equal_the_mode_off_bitwise():
    code = SCENE + '''
import json, numpy as np
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession
sc = build(still=True, cut_at=3)
setup_scene(sc, None)
on = RenderSession(sc, [1, 2, 3], write=False, keep_groups=True, temporal="on")
on.run()
off = RenderSession(sc, [2, 3], write=False, keep_groups=True, temporal="off")
off.run()
on_r = {r["frame"]: r for r in on.results}
res = {f: dict(equal=bool(np.array_equal(on_r[f]["prediction"], r["prediction"])),
               history=on_r[f]["history_frames"], coverage=on_r[f]["history_coverage"])
       for f, r in ((r["frame"], r) for r in off.results)}
res["vector_max"] = float(np.abs(on_r[2]["groups"]["vector"]).max())
print("RESULT", json.dumps(res))
'''
    p = run_py(code, timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["vector_max"] == 0.0
    assert res["2"]["history"] == [1] and res["2"]["coverage"][0] > 0.9 and res["2"]["equal"], res  # still
    assert res["3"]["history"] == [] and res["3"]["equal"], res  # the cut
