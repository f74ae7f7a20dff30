"""The sky group (ssgi_addon/blender/sky.py, model/sky.py): the world's L1 light at the normal, without a render of
the scene, matches EEVEE's own world pass (passes.render_world) whichever way the camera looks; the world's render is
made once and made again when the world changes; a black world costs no render; a one-render bake stores the group and
scripts/add_surround.py --group sky fills a baked folder with what render_gbuffer gives."""
from __future__ import annotations

import json

from ..conftest import ROOT, run_py

SCENE = f"""
import json, math, sys
import numpy as np
import bpy
sys.path.insert(0, {str(ROOT)!r})
from scenes import artist as artist_scenes
from ssgi.ssgi_addon.blender import passes, sky as sky_addon
from ssgi.model import sky as sky_model
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
artist_scenes.build_exterior(sc)   # a sky texture with a sun: light from one side
artist_scenes.render_settings(sc, (96, 54))
out = {{}}
for turn in (0.0, 2.0):            # the camera turned about the world's up axis (radians)
    sc.camera.rotation_euler[2] += turn
    world = passes.render_world(sc)
    g = passes.render_gbuffer(sc, ("sky",), samples=1)
    n = passes.render_gbuffer(sc, ("normal",), samples=1)["normal"]
    geo = np.linalg.norm(n, axis=-1) > 0.5
    sky = g["sky"]
    coef = sky_addon.world_coefficients(sc.world)
    out[str(turn)] = dict(keys=sorted(g), shape=list(sky.shape), world=float(world[geo].mean()),
                          rel=float(np.abs(sky - world)[geo].mean() / world[geo].mean()),
                          # the camera's rotation left out: what normals taken for world-space ones would give
                          rel_unturned=float(np.abs(sky_model.irradiance(coef, n, np.eye(3)) - world)[geo].mean()
                                             / world[geo].mean()),
                          spread=float(world[geo].std() / world[geo].mean()),
                          background=float(np.abs(sky[~geo]).max()) if (~geo).any() else 0.0)
out["renders_two_views"] = sky_addon.renders   # one world: one render of it, kept for the second view
tex = next(n for n in sc.world.node_tree.nodes if n.bl_idname == "ShaderNodeTexSky")
before = sky_addon.world_coefficients(sc.world)
tex.sun_elevation += 0.3                        # the world changed: a new render
out["changed"] = float(np.abs(sky_addon.world_coefficients(sc.world) - before).max())
out["renders_changed"] = sky_addon.renders
sc.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
g = passes.render_gbuffer(sc, ("sky", "normal"), samples=1)
out["black"] = dict(max=float(g["sky"].max()), keys=sorted(g))
print("JSON" + json.dumps(out))
"""


def test_the_sky_group_is_eevee_s_world_light_without_a_render_whichever_way_the_camera_looks():
    out = json.loads(run_py(SCENE, timeout=400).stdout.split("JSON", 1)[1])
    for turn in ("0.0", "2.0"):
        r = out[turn]
        assert r["keys"] == ["sky"] and r["shape"] == [54, 96, 3]
        assert r["world"] > 0.05 and r["spread"] > 0.1  # a world whose light depends on the normal
        assert r["rel"] < 0.05, r  # measured 2.3 %
        assert r["rel_unturned"] > 2 * r["rel"], r
        assert r["background"] == 0.0
    assert out["renders_two_views"] == 1 and out["renders_changed"] == 2 and out["changed"] > 0.01
    assert out["black"]["max"] == 0.0 and out["black"]["keys"] == ["normal", "sky"]


def test_a_one_render_bake_holds_the_sky_and_add_surround_fills_an_older_folder_with_the_same(tmp_path):
    import subprocess
    import sys

    import numpy as np

    from ssgi.model.dataset import exrio

    from ..conftest import run_cli, strip_group

    d = tmp_path / "data"
    run_cli("bake", "--count", "1", "--seed", "5", "--size", "32x18", "--ref-samples", "2", "--gi-samples", "1",
            "--one-render", "--mode", "artist", "--out", str(d))
    baked = exrio.read_sample(d / "000000.exr")
    geo = np.linalg.norm(baked["normal"], axis=-1) > 0.5
    assert baked["sky"].shape == (18, 32, 3) and baked["sky"][geo].mean() > 0.01  # an artist room has a sky
    assert (baked["sky"][~geo] == 0).all()
    # the folder as an older bake wrote it: no sky channels, a manifest without the group
    strip_group(d, "sky")
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "add_surround.py"), "--group", "sky", str(d)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    assert res["filled"] == 1 and res["not_filled"] == {} and res["manifest_lists_it"]
    filled = exrio.read_sample(d / "000000.exr")
    np.testing.assert_allclose(filled["sky"], baked["sky"], rtol=0.02, atol=1e-3)
    for g in baked:
        if g != "sky":
            np.testing.assert_array_equal(filled[g], baked[g])
    assert "sky" in {g["name"] for g in json.loads((d / "manifest.json").read_text())["channel_spec"]}


def test_the_shipped_one_render_model_renders_a_sky_lit_scene_from_its_one_render_and_the_sky(tmp_path):
    import numpy as np

    from ssgi.model import channels as ch
    from ssgi.model.dataset import exrio
    from ssgi.model.infer.compose import compose
    from ssgi.model.infer.predictor import load_predictor

    from ..conftest import run_cli
    from .test_node import read_rgba

    model = ROOT / "models" / "ssgi_one_render.pt"
    blend = tmp_path / "exterior.blend"
    run_py(f"""
import sys
import bpy
sys.path.insert(0, {str(ROOT)!r})
from scenes import artist as artist_scenes
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
artist_scenes.build_exterior(sc)
artist_scenes.render_settings(sc, (64, 36))
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
""", timeout=200)
    p = run_cli("render", "--blend", str(blend), "--out", str(tmp_path / "frame.exr"), "--model", str(model),
                "--samples", "2", "--setup", "--save-passes", str(tmp_path / "passes"), "--temporal", "off", "--json",
                timeout=400)
    s = json.loads(p.stdout)
    assert s["model"] == str(model) and "sky" in s["inputs"].split(",")
    pred = load_predictor(model, num_threads=1)
    g = exrio.read_sample(tmp_path / "passes" / "000001.exr", groups=ch.required_groups(tuple(pred.spec)))
    geo = np.linalg.norm(g["normal"], axis=-1) > 0.5
    assert g["sky"][geo].mean() > 0.05 and (g["sky"][~geo] == 0).all()  # the Sky Texture's light, without a render
    want = compose(pred.predict(g), g, pred.target)
    got = read_rgba(tmp_path / "frame.exr")
    assert got.shape[:2] == (36, 64)
    np.testing.assert_allclose(got[..., :3][geo], want[geo], rtol=2e-3, atol=2e-3)
    assert np.abs(got[..., :3] - g["eevee_combined"])[geo].mean() > 1e-3  # the network changed EEVEE's image
