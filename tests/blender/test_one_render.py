"""One-render models (docs/one_render.md). Every group such a model reads comes from ONE EEVEE
render, the artist-settings render that gives ``rest``, made with ray tracing and fast GI on: ``eevee_diffuse``
(its Diffuse Direct pass, EEVEE's own diffuse light) and albedo, normal, depth, emission, the motion vectors.
Real EEVEE and Cycles at tiny sizes: the pass call makes one render and gives what separate renders give; a
``--gi-samples`` bake holds what such a model reads and nothing it does without; a model trained on it renders
through the node with one EEVEE render per frame and keeps the emitter, metal and glass."""
from __future__ import annotations

import json

from ..conftest import ROOT, run_cli, run_py
from .test_pass_merge import TINY_SKY_SCENE

PASSES = TINY_SKY_SCENE + r'''
sc.eevee.use_raytracing = sc.eevee.use_fast_gi = False  # the artist's: the one-render call switches both on
groups = ("albedo", "normal", "depth", "emission", "eevee_diffuse", "surround", "rest", "vector")
# (EEVEE's Normal pass, as a bake stores it: a frame's own default, the normals from the depth, is
# test_pass_merge.py's test_a_one_render_frame_takes_its_normals_from_the_depth...)
one = passes.render_gbuffer(sc, groups, samples=2, rest_samples=2, normals="pass")
res = {"renders": sorted(passes.last_timings), "sources": dict(passes.last_sources),
       "rt_after": [sc.eevee.use_raytracing, sc.eevee.use_fast_gi]}
rest, _comb, light = passes.render_rest(sc, 2, groups=("eevee_diffuse",), gi=True)
plain = passes.render_rest(sc, 2, groups=("eevee_diffuse",))[2]["eevee_diffuse"]  # ray tracing, fast GI off
sep = passes.render_gbuffer(sc, ("albedo", "normal", "depth", "emission", "direct"), samples=2, merge=False)
res["vs_own_render"] = {"eevee_diffuse": float(np.abs(one["eevee_diffuse"] - light["eevee_diffuse"]).max()),
                        "rest": float(np.abs(one["rest"] - rest).max())}
res["vs_direct_only"] = {g: float(np.abs(one[g] - sep[g]).max()) for g in ("albedo", "normal", "depth", "emission")}
res["gi_vs_plain_mean"] = float(np.abs(one["eevee_diffuse"] - plain).mean())
geo = one["depth"][..., 0] < 0.999 * sc.camera.data.clip_end
res["diffuse_mean"] = float(one["eevee_diffuse"][geo].mean())
res["direct_mean"] = float(sep["direct"][geo].mean())
res["vector_shape"] = list(one["vector"].shape)
print("RESULT", json.dumps(res))
'''


def test_a_one_render_call_makes_one_eevee_render_with_ray_tracing_and_fast_gi_and_puts_them_back():
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + PASSES, timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["renders"] == ["rest", "surround"], res["renders"]  # surround is ray casts, not a render
    assert all(v == "rest" for k, v in res["sources"].items() if k != "surround"), res["sources"]
    assert res["rt_after"] == [False, False], res  # the artist's settings are back
    # the groups are those of EEVEE's own render with ray tracing + fast GI, and of the direct-only render
    assert max(res["vs_own_render"].values()) <= 1e-6, res["vs_own_render"]
    assert max(res["vs_direct_only"].values()) <= 1e-6, res["vs_direct_only"]
    # ... and ray tracing + fast GI were on: EEVEE's diffuse light is not the plain render's
    assert res["gi_vs_plain_mean"] > 1e-3, res
    # EEVEE's own diffuse light holds the lamp's and the sky's: more than the hard direct light alone
    assert res["diffuse_mean"] > res["direct_mean"] > 0, res
    assert res["vector_shape"][-1] == 4


RENDER = r'''
import json, sys
import numpy as np
import bpy
from bpy_extras.object_utils import world_to_camera_view
sys.path.insert(0, str(ROOT))
from scenes import artist as artist_scenes
from ssgi.ssgi_addon.blender import passes
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession

model = sys.argv[1]
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
names = artist_scenes.tiny_material_scene(sc)
sc.eevee.taa_render_samples = 2
W, H = sc.render.resolution_x, sc.render.resolution_y

def patch(img, name):
    v = world_to_camera_view(sc, sc.camera, bpy.data.objects[name].matrix_world.translation)
    y, x = int(round((1 - v.y) * H - 0.5)), int(round(v.x * W - 0.5))
    return float(img[max(0, y - 1):y + 2, max(0, x - 1):x + 2, :3].mean())

setup_scene(sc, model)
eevee_own = passes.render_rest(sc)[1]
s = RenderSession(sc, model=model, write=False, keep_groups=True)
s.run()
r = s.results[0]
img = r["prediction"]
res = {"renders": sorted(r["t_pass_renders"]),
       "groups": sorted(r["groups"]), "finite": bool(np.isfinite(img).all()),
       "ssgi": {k: patch(img, names[k]) for k in ("emissive", "metal", "glass")},
       "eevee": {k: patch(eevee_own, names[k]) for k in ("emissive", "metal", "glass")},
       "mean": float(img.mean())}
print("RESULT", json.dumps(res))
'''


def test_a_one_render_bake_trains_a_model_that_the_node_renders_with_one_eevee_render(tmp_path):
    data = tmp_path / "gi"
    run_cli("bake", "--out", str(data), "--count", "2", "--seed", "60000", "--mode", "artist", "--size", "48x27",
            "--denoise", "--ref-samples", "2", "--gi-samples", "2", timeout=900)
    m = json.loads((data / "manifest.json").read_text())
    held = {g["name"] for g in m["channel_spec"] if "channels" in g}
    assert {"eevee_diffuse", "rest", "albedo", "surround", "ref_diffuse"} <= held, held
    assert not held & {"world", "direct_soft", "emit_direct"}, held  # the renders a one-render model does without
    assert m["settings"]["eevee"]["one_render"]["gi_samples"] == 2
    # a second run resumes: nothing to bake
    p = run_cli("bake", "--out", str(data), "--count", "2", "--seed", "60000", "--mode", "artist", "--size", "48x27",
                "--denoise", "--ref-samples", "2", "--gi-samples", "2", "--json", timeout=900)
    assert json.loads(p.stdout)["baked"] == 0
    model = tmp_path / "gi.pt"
    run_cli("train", "--data", str(data), "--out", str(model), "--variant", "unet_s_gi", "--inputs",
            "albedo,normal,depth,emission,eevee_diffuse,scene_gi,glow,surround", "--epochs", "1", "--crop", "16",
            "--batch", "2", "--val-fraction", "0.5", timeout=900)
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + RENDER, str(model), timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["renders"] == ["rest", "surround"], res["renders"]  # one EEVEE render a frame, no other
    assert "eevee" not in res["groups"] and "direct" not in res["groups"], res["groups"]
    assert res["finite"] and res["mean"] > 0.01, res
    for k in ("emissive", "metal", "glass"):  # EEVEE's own rendering of them is kept: never black
        assert res["ssgi"][k] >= 0.5 * res["eevee"][k] > 0.01, (k, res)
