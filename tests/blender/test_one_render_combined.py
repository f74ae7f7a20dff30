"""GI-off one-render models that read the render's Combined image instead of its Diffuse Direct pass
(docs/one_render.md). Such a frame is one EEVEE render (ray tracing and fast GI off, the emitter proxies on)
without a Diffuse Direct pass, so no rest. ``cli.py fit --one-render`` bakes the views of that render with its Combined image (``eevee_combined``) and fits scratch networks with
head ``residual_combined`` on target ``ref_combined``; the node composes EEVEE's image + the prediction. Real EEVEE and
Cycles at tiny sizes."""
from __future__ import annotations

import json

import pytest

from ..conftest import ROOT, cornell_script, one_render_shot_fit, run_py

PASSES = cornell_script(2) + r'''
import OpenEXR
from ssgi.ssgi_addon.blender import passes
sc.eevee.use_raytracing = sc.eevee.use_fast_gi = True   # the artist's: the GI-off call switches both off

def written(groups):
    """(groups, the passes of the render's read-back file, the renders made)"""
    with passes.keep_render_file() as kept:
        out = passes.render_gbuffer(sc, groups, samples=2, rest_samples=2)
    names = {c.name.split(".")[-2] if c.name.count(".") else c.name
             for part in OpenEXR.File(kept.path, header_only=True).parts for c in part.header["channels"]}
    kept.discard()
    return out, sorted(names), sorted(passes.last_timings)

comb, comb_passes, comb_renders = written(("albedo", "normal", "depth", "emission", "eevee_combined", "surround"))
local, local_passes, _ = written(("albedo", "normal", "depth", "emission", "eevee_local", "surround", "rest"))
geo = comb["depth"][..., 0] < 0.999 * sc.camera.data.clip_end
recomposed = local["rest"] + local["albedo"] * local["eevee_local"]
print("RESULT", json.dumps({
    "renders": comb_renders, "groups": sorted(comb), "passes": comb_passes, "local_passes": local_passes,
    "vs_beauty": float(np.abs(comb["eevee_combined"] - comb["beauty"][..., :3]).max()),
    "vs_local": float(np.abs(comb["eevee_combined"] - recomposed).max()),
    "mean": float(comb["eevee_combined"][geo].mean()),
    "rt_after": [sc.eevee.use_raytracing, sc.eevee.use_fast_gi]}))
'''


def test_the_combined_one_render_writes_no_diffuse_direct_pass_and_gives_the_local_renders_image():
    p = run_py(PASSES, timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["renders"] == ["rest", "surround"], res["renders"]  # one EEVEE render (surround: ray casts)
    assert "rest" not in res["groups"] and "eevee_combined" in res["groups"], res["groups"]
    # the pass the local model reads and this one does not: the render writes one pass fewer
    assert "DiffDir" in res["local_passes"] or "Diffuse Direct" in " ".join(res["local_passes"]), res["local_passes"]
    assert not any("DiffDir" in n or "Diffuse Direct" in n for n in res["passes"]), res["passes"]
    assert res["vs_beauty"] == 0.0, res  # eevee_combined is the render's Combined image ...
    # ... which is the local render's rest + albedo x its Diffuse Direct light (the same GI-off render, proxies on)
    assert res["vs_local"] <= 1e-4 and res["mean"] > 0.05, res
    assert res["rt_after"] == [True, True], res


def test_a_one_render_fit_reads_the_combined_image_and_no_diffuse_direct():
    import argparse

    from ssgi.model import channels as ch
    from ssgi.model.errors import UserError
    from ssgi.model.evaluate.fit_report import SHOT_BAR_DB
    from ssgi.model.infer import lightmap
    from ssgi.model.learn.fit import LADDER
    from ssgi.ssgi_addon import props
    from ssgi.ssgi_addon.blender import views
    from ssgi.ssgi_addon.commands import bake as cbake, fit as cfit
    from ssgi.ssgi_addon.pipeline import fit as pfit
    from ssgi.ssgi_addon.pipeline.bake import ONE_RENDER_BAKE_GROUPS, BakeConfig

    ladder, target, inputs = pfit.one_render_ladder(None, shot=True)
    assert [r[0] for r in ladder] == [r[0] for r in LADDER] and all(r[2]["head"] == "residual_combined" for r in ladder)
    assert all(r[2]["widths"] == l[2]["widths"] for r, l in zip(ladder, LADDER))  # the ladder's sizes are kept
    assert target == SHOT_BAR_DB and pfit.one_render_ladder(31.0, shot=True)[1] == 31.0
    spec = ch.parse_spec(inputs)
    assert set(ch.required_groups(spec)) <= set(ONE_RENDER_BAKE_GROUPS) and "eevee_local" not in spec, spec
    assert not set(spec) & {"direct", "world", "direct_soft", "emit_direct", "lit", "scene"}, spec
    # (the fit's report and comparisons, a shot's reflection map)
    assert {"eevee_combined", "eevee_local", "rest", "gloss"} <= set(ONE_RENDER_BAKE_GROUPS)
    assert lightmap.known_for(ch.required_groups(spec)) == ()  # no known light: the field is the light it adds
    with pytest.raises(UserError, match="--data"):
        pfit.FitSceneConfig(out="x.pt", data="views", one_render=True).check()
    # --one-render is a plain flag of both commands, off by default in both; the Fit panel has no other choice
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers()
    cfit.register_cli(sub)
    cbake.register_cli(sub)
    assert ap.parse_args(["fit", "--out", "x.pt", "--one-render"]).one_render is True
    assert ap.parse_args(["fit", "--out", "x.pt"]).one_render is False
    assert ap.parse_args(["bake", "--out", "d", "--gi-samples", "4", "--one-render"]).one_render is True
    assert ap.parse_args(["bake", "--out", "d"]).one_render is False
    with pytest.raises(SystemExit):
        ap.parse_args(["fit", "--out", "x.pt", "--one-render", "local"])
    assert "fit_one_render_kind" not in props.SSGI_SceneSettings.__annotations__
    # a one-render bake needs its samples, and the samples need the flag
    with pytest.raises(UserError, match="--gi-samples"):
        BakeConfig(out="d", one_render=True).check()
    with pytest.raises(UserError, match="--one-render"):
        BakeConfig(out="d", gi_samples=4).check()
    BakeConfig(out="d", gi_samples=4, one_render=True).check()
    # views of a one render are not the views of another fit
    plan = {"scene": "S", "frames": [1], "cameras": ["c"], "size": [8, 8], "seed": 0}
    blend = ROOT / "blender_manifest.toml"  # (any file: the tag hashes its bytes)
    assert views.views_tag(blend, plan) != views.views_tag(blend, plan | {"one_render": 2, "one_render_kind": "combined"})


NODE = r'''
import json, sys
import numpy as np
import bpy
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession

model, blend = sys.argv[1], sys.argv[2]
bpy.ops.wm.open_mainfile(filepath=blend)
sc = bpy.context.scene
setup_scene(sc, model)
s = RenderSession(sc, frames=[5], model=model, write=False, keep_groups=True)
s.run()
r = s.results[0]
g = r["groups"]
geo = g["depth"][..., 0] < 0.999 * sc.camera.data.clip_end
print("RESULT", json.dumps({"renders": sorted(r["t_pass_renders"]), "groups": sorted(g),
                            "finite": bool(np.isfinite(r["prediction"]).all()), "mean": float(r["prediction"].mean()),
                            "added": float((r["prediction"] - g["eevee_combined"])[geo].mean()),
                            "lightmap": s.lightmap is not None, "reflmap": s.reflmap is not None}))
'''

@pytest.mark.timeout(1800)
def test_a_combined_one_render_shot_fit_beats_eevee_and_the_node_renders_it_without_diffuse_direct(tmp_path):
    blend, model, summary, ck = one_render_shot_fit(tmp_path)
    arch = ck["arch"]
    assert arch["head"] == "residual_combined" and arch["target"] == "ref_combined", arch
    assert {"albedo", "eevee_combined"} <= set(arch["inputs"]) and "eevee_local" not in arch["inputs"], arch
    m = json.loads(next((model.parent / "shot.fit").glob("views-*/manifest.json")).read_text())
    assert m["settings"]["eevee"]["one_render"]["kind"] == "combined", m["settings"]["eevee"]["one_render"]
    # the mirror ball: EEVEE's GI-off image is corrected where the albedo is black, by the shot's reflection map
    assert model.with_suffix(".reflmap.npz").exists()
    w = summary["withheld"]["methods"]
    assert w["fitted"]["psnr"] > w["eevee_gi"]["psnr"] + 3.0, (w["fitted"]["psnr"], w["eevee_gi"]["psnr"])
    p = run_py(NODE, str(model), str(blend), timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert set(res["renders"]) <= {"rest", "surround"} and "rest" in res["renders"], res["renders"]
    assert not set(res["groups"]) & {"rest", "eevee_local", "direct", "world", "eevee"}, res["groups"]
    assert {"gloss", "eevee_combined_eevee"} <= set(res["groups"]) and res["reflmap"], res  # (EEVEE's own kept)
    # the image is EEVEE's GI-off render with light added (the panel's bounce light it lacks)
    assert res["finite"] and res["added"] > 0.005, res
