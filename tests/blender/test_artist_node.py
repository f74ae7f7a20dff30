"""A model that predicts the diffuse part keeps what EEVEE renders itself. Through the SSGI render
path (set up by setup_scene, rendered by RenderSession) on a tiny scene with an emissive panel, a metal
sphere, a glass cube and a glossy plane (scenes/artist.py tiny_material_scene), real EEVEE at
64x36: the diffuse-part model's image shows each of them as EEVEE's own render does, and a whole-image model
(the first models) renders them black, the failure the diffuse-part target exists to avoid."""
from __future__ import annotations

import json

from ..conftest import ROOT, run_py

CODE = r'''
import json, sys
import numpy as np
import bpy, torch
from bpy_extras.object_utils import world_to_camera_view
sys.path.insert(0, str(ROOT))
from scenes import artist as artist_scenes
from ssgi.model.learn import checkpoint, network
from ssgi.ssgi_addon.blender import passes
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession

out_dir = sys.argv[1]
models = {}
for target in ("ref_diffuse", "ref"):
    torch.manual_seed(0)
    net = network.build(network.arch_for("unet_s", "albedo,normal,depth,direct,emission,lit", target=target))
    p = f"{out_dir}/{target}.pt"
    checkpoint.save(p, checkpoint.make(net, "network"))
    models[target] = p

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
names = artist_scenes.tiny_material_scene(sc)
sc.eevee.taa_render_samples = 4
W, H = sc.render.resolution_x, sc.render.resolution_y

def pixel(co):
    v = world_to_camera_view(sc, sc.camera, co)
    return int(round((1 - v.y) * H - 0.5)), int(round(v.x * W - 0.5))  # row from the top, column

def patch(img, name):
    y, x = pixel(bpy.data.objects[name].matrix_world.translation)
    return float(img[max(0, y - 1):y + 2, max(0, x - 1):x + 2, :3].mean())

def region_max(img, name):
    o = bpy.data.objects[name]
    pts = [pixel(o.matrix_world @ __import__("mathutils").Vector(c)) for c in o.bound_box]
    ys, xs = [p[0] for p in pts], [p[1] for p in pts]
    y0, y1 = max(0, min(ys)), min(H, max(ys) + 1)
    x0, x1 = max(0, min(xs)), min(W, max(xs) + 1)
    return float(img[y0:y1, x0:x1, :3].max())

eevee_own = passes.render_rest(sc)[1]  # EEVEE's own render at the scene's settings
res = {"eevee": {r: patch(eevee_own, names[r]) for r in ("emissive", "metal", "glass")},
       "eevee_glossy_max": region_max(eevee_own, names["glossy"])}
for target, path in models.items():
    setup_scene(sc, path)
    s = RenderSession(sc, model=path, write=False, keep_groups=True)
    s.run()
    img = s.results[0]["prediction"]
    res[target] = {r: patch(img, names[r]) for r in ("emissive", "metal", "glass")}
    res[target + "_glossy_max"] = region_max(img, names["glossy"])
    res[target + "_groups"] = sorted(s.results[0]["groups"])
print("RESULT", json.dumps(res))
'''


def test_emission_metal_glass_and_highlights_are_kept_by_a_diffuse_part_model(tmp_path):
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + CODE, str(tmp_path), timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    ee = res["eevee"]
    assert min(ee.values()) > 0.02, ee  # the scene shows each of them in EEVEE's own render
    new, old = res["ref_diffuse"], res["ref"]
    assert "rest" in res["ref_diffuse_groups"] and "rest" not in res["ref_groups"]
    for role in ("emissive", "metal", "glass"):
        # never black: at least EEVEE's own non-diffuse light there (the prediction only adds diffuse light)
        assert new[role] >= 0.5 * ee[role], (role, new, ee)
        # the whole-image path drops them (zero albedo: a black panel and ball)
        assert old[role] < 0.2 * ee[role], (role, old, ee)
    # the glossy plane's highlight is kept
    assert res["ref_diffuse_glossy_max"] >= 0.8 * res["eevee_glossy_max"], res
