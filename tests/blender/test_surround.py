"""The surround group (ssgi_addon/blender/surround.py): rays from the camera tell a closed room from an open
stage, the values follow the camera and not the scene's scale, the mirror augmentation swaps its right and left
bins, and scripts/add_surround.py fills an old folder with what the baker writes."""
from __future__ import annotations

import json

import numpy as np
import torch

from ssgi.model import channels as ch, normalize
from ssgi.model.dataset import exrio

from ..conftest import ROOT, run_cli, run_py, strip_group

BOX = """
import json, math
import bpy, numpy as np
from ssgi.ssgi_addon.blender import surround, passes
from ssgi.model import channels as ch
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
def plane(loc, rot, size):
    bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
H = 4.0
walls = {"floor": ((0, 0, 0), (0, 0, 0)), "ceiling": ((0, 0, H), (0, 0, 0)),
         "back": ((0, 3, H / 2), (math.pi / 2, 0, 0)), "front": ((0, -3, H / 2), (math.pi / 2, 0, 0)),
         "left": ((-3, 0, H / 2), (0, math.pi / 2, 0)), "right": ((3, 0, H / 2), (0, math.pi / 2, 0))}
for name, (loc, rot) in walls.items():
    plane(loc, rot, 6.0)
    bpy.context.active_object.name = name
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
scene.collection.objects.link(cam)
scene.camera = cam
cam.location = (0, 0, 1.6)
cam.rotation_euler = (math.pi / 2, 0, 0)   # looks along +Y (at the "back" wall), up is +Z, right is +X
out = {"closed": surround.probe(scene).tolist()}
bpy.data.objects.remove(bpy.data.objects["front"])   # the wall behind the camera
out["no_wall_behind"] = surround.probe(scene).tolist()
cam.rotation_euler = (math.pi / 2, 0, math.pi)        # turned round: the opening is in front now
out["turned"] = surround.probe(scene).tolist()
for o in scene.objects:                                # the same scene 10x larger
    o.location = tuple(10 * v for v in o.location)
    if o.type == "MESH":
        o.scale = (10, 10, 10)
cam.data.clip_end = 1000
out["scaled"] = surround.probe(scene).tolist()
passes.set_resolution(scene, 16, 9)
g = passes.render_gbuffer(scene, ("surround",))
out["group_shape"] = list(g["surround"].shape)
out["group_constant"] = bool((g["surround"] == g["surround"][0, 0]).all())
out["group_is_probe"] = bool(np.array_equal(g["surround"][0, 0], surround.probe(scene)))
print("JSON" + json.dumps(out))
"""


def _bin(v, b, k):
    return v[2 * ch.SURROUND_BINS.index(b) + (k == "N")]


def test_rays_tell_a_closed_room_from_an_open_one_follow_the_camera_and_ignore_scale():
    out = json.loads(run_py(BOX, timeout=300).stdout.split("JSON", 1)[1])
    closed, open_b, turned = out["closed"], out["no_wall_behind"], out["turned"]
    assert all(_bin(closed, b, "O") == 0.0 for b in ch.SURROUND_BINS)  # walls all round
    assert all(0.1 < _bin(closed, b, "N") <= 1.0 for b in ch.SURROUND_BINS)
    # the camera at y = 0 of a 6 m box looks at the wall 3 m ahead: the back wall is gone, the rays there escape
    # (steep rays of the back bin still hit the floor, ceiling and side walls before the missing wall)
    assert _bin(open_b, "B", "O") > 0.5 and _bin(open_b, "F", "O") == 0.0 and _bin(open_b, "B", "N") < _bin(closed, "B", "N") - 0.2
    assert _bin(turned, "F", "O") > 0.5 and _bin(turned, "B", "O") == 0.0
    assert _bin(open_b, "U", "O") == _bin(open_b, "D", "O") == 0.0
    np.testing.assert_allclose(out["scaled"], turned, atol=1e-6)  # scale free (m / (d + m))
    assert out["group_shape"] == [9, 16, 12] and out["group_constant"] and out["group_is_probe"]


def test_the_mirror_swaps_right_and_left_bins_in_numpy_and_torch():
    spec = ("albedo", "surround", "normal")
    rng = np.random.default_rng(0)
    x = rng.random((4, 6, ch.input_channels(spec)), dtype=np.float32)
    lay = normalize.layout(spec)
    y = normalize.flip_x(x, spec)
    s_x, s_y = x[..., lay["surround"]], y[..., lay["surround"]]
    r, left = ch.SURROUND_COMPONENTS.index("RO"), ch.SURROUND_COMPONENTS.index("LO")
    np.testing.assert_array_equal(s_y[:, ::-1, r:r + 2], s_x[..., left:left + 2])
    np.testing.assert_array_equal(s_y[:, ::-1, left:left + 2], s_x[..., r:r + 2])
    u = ch.SURROUND_COMPONENTS.index("UO")
    np.testing.assert_array_equal(s_y[:, ::-1, u:], s_x[..., u:])  # up, down, front, back stay
    np.testing.assert_array_equal(normalize.flip_x(y, spec), x)  # twice: the identity
    t = torch.from_numpy(x).permute(2, 0, 1)[None]
    np.testing.assert_array_equal(normalize.flip_x(t, spec, axis=1)[0].permute(1, 2, 0).numpy(), y)


def test_add_surround_fills_an_old_folder_as_the_baker_writes_it(tmp_path):
    d = tmp_path / "data"
    run_cli("bake", "--count", "1", "--seed", "3", "--size", "32x18", "--ref-samples", "2", "--out", str(d))
    baked = exrio.read_sample(d / "000000.exr")
    assert "surround" in baked and (baked["surround"] == baked["surround"][0, 0]).all()
    # the folder as an older bake wrote it: no surround channels, a manifest without the group
    strip_group(d, "surround")
    import subprocess
    import sys
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "add_surround.py"), str(d)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["filled"] == 1 and res["not_filled"] == {} and res["manifest_lists_it"]
    filled = exrio.read_sample(d / "000000.exr")
    np.testing.assert_array_equal(filled["surround"], baked["surround"])
    for g in baked:
        np.testing.assert_array_equal(filled[g], baked[g])
    assert "surround" in {g["name"] for g in json.loads((d / "manifest.json").read_text())["channel_spec"]}
    again = subprocess.run([sys.executable, str(ROOT / "scripts" / "add_surround.py"), str(d)], capture_output=True,
                           text=True, timeout=300)
    assert json.loads(again.stdout.strip().splitlines()[-1])["had_it"] == 1  # a second run changes nothing
    bad = subprocess.run([sys.executable, str(ROOT / "scripts" / "add_surround.py"), str(tmp_path / "none")],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "none: no manifest.json" in bad.stderr and "Traceback" not in bad.stderr


def test_features_stay_finite_for_a_camera_on_a_surface_and_with_nothing_around():
    import bpy  # noqa: F401  (mathutils comes with it)

    from ssgi.ssgi_addon.blender import surround
    dirs = surround.directions()
    assert np.bincount(surround.bins(dirs), minlength=6).min() >= 40  # every bin holds rays
    on_floor = surround.features(np.zeros(len(dirs)), dirs)
    nothing = surround.features(np.full(len(dirs), np.inf), dirs)
    assert np.isfinite(on_floor).all() and np.isfinite(nothing).all()
    assert (nothing[0::2] == 1).all() and (nothing[1::2] == 0).all() and (on_floor[0::2] == 0).all()
