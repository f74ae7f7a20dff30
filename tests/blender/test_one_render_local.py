"""GI-off one-render models (docs/one_render.md). A frame of such a model is ONE EEVEE
render with ray tracing and fast GI switched off and an area light standing in for each planar emitter, casting
no shadow (``passes.ONE_RENDER_MODES["eevee_local"]``; a model baked with shadowed proxies gets
them) and only on the sides of an emitter that face open space (``passes.PROXY_SIDES_LOCAL``): its Diffuse Direct pass is ``eevee_local``, and albedo, normal, depth,
emission, rest and gloss come from it too. ``cli.py fit --one-render`` bakes views of that render and fits scratch
networks (head ``residual_local``) on them. Real EEVEE and Cycles at tiny sizes: the pass call makes one render with
GI off and proxies on and puts the artist's settings back; a tiny one-render shot fit writes a model that reads
only that render, and the node renders its frames with that one render."""
from __future__ import annotations

import json

import pytest

from ..conftest import cornell_script, one_render_shot_fit, run_py

PASSES = cornell_script(2) + r'''
from ssgi.ssgi_addon.blender import passes
sc.eevee.use_raytracing = sc.eevee.use_fast_gi = True   # the artist's: the GI-off call switches both off
n_lights = len(bpy.data.lights)
groups = ("albedo", "normal", "depth", "emission", "eevee_local", "surround", "rest", "gloss")
one = passes.render_gbuffer(sc, groups, samples=2, rest_samples=2)
res = {"renders": sorted(passes.last_timings), "sources": dict(passes.last_sources),
       "rt_after": [sc.eevee.use_raytracing, sc.eevee.use_fast_gi], "lights_after": len(bpy.data.lights) - n_lights}
_gi, _p, shadows = passes.ONE_RENDER_MODES["eevee_local"]
sides = passes.PROXY_SIDES_LOCAL
rest, _c, own = passes.render_rest(sc, 2, groups=("eevee_local", "gloss"), gi=False, proxies=True, proxy_shadows=shadows,
                                   proxy_sides=sides)
gi_on = passes.render_rest(sc, 2, groups=("eevee_local",), gi=True, proxies=True,
                           proxy_shadows=shadows, proxy_sides=sides)[2]["eevee_local"]
# the proxies' sides: only the panel's downward side faces open space; a model baked with a proxy on
# both sides gets both (render_gbuffer's proxy_sides, which the node takes from the model)
both = passes.render_gbuffer(sc, ("depth", "eevee_local"), samples=2, rest_samples=2, proxy_sides="both")
own_both = passes.render_rest(sc, 2, groups=("eevee_local",), gi=False, proxies=True, proxy_shadows=shadows,
                              proxy_sides="both")[2]["eevee_local"]
d = np.abs(both["eevee_local"] - one["eevee_local"]).max(-1)
res["sides"] = {"default": sides, "vs_own_both": float(np.abs(both["eevee_local"] - own_both).max()),
                "max_diff": float(d.max()), "frac_diff": float((d > 1e-3).mean())}
# the proxies' shadows: the one render's default (unshadowed), and a model that was trained on
# shadowed ones gets them (render_gbuffer's proxy_shadows, which the node takes from the model)
shadowed = passes.render_gbuffer(sc, ("depth", "eevee_local"), samples=2, rest_samples=2, proxy_shadows=True)
own_shadowed = passes.render_rest(sc, 2, groups=("eevee_local",), gi=False, proxies=True,
                                  proxy_shadows=True, proxy_sides=sides)[2]["eevee_local"]
res["shadows"] = {"default": shadows, "vs_own_shadowed": float(np.abs(shadowed["eevee_local"] - own_shadowed).max())}
no_proxy = passes.render_rest(sc, 2, groups=("eevee_local",), gi=False)[2]["eevee_local"]
res["vs_own_render"] = {"eevee_local": float(np.abs(one["eevee_local"] - own["eevee_local"]).max()),
                        "gloss": float(np.abs(one["gloss"] - own["gloss"]).max()),
                        "rest": float(np.abs(one["rest"] - rest).max())}
geo = one["depth"][..., 0] < 0.999 * sc.camera.data.clip_end
res["mean"] = {"local": float(one["eevee_local"][geo].mean()), "no_proxy": float(no_proxy[geo].mean()),
               "shadowed": float(own_shadowed[geo].mean()),
               "darker_shadowed": float((own_shadowed[geo] < one["eevee_local"][geo] - 0.02).mean()),
               "gi_on_vs_off": float(np.abs(gi_on - own["eevee_local"])[geo].mean())}
try:
    passes.render_gbuffer(sc, ("albedo", "eevee_local", "eevee_diffuse"), samples=1)
    res["both"] = "no error"
except ValueError as e:
    res["both"] = str(e)
print("RESULT", json.dumps(res))
'''


def test_a_gi_off_one_render_call_makes_one_render_with_gi_off_and_proxies_on_and_puts_them_back():
    p = run_py(PASSES, timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["renders"] == ["rest", "surround"], res["renders"]  # one EEVEE render (surround: ray casts)
    assert all(v == "rest" for k, v in res["sources"].items() if k != "surround"), res["sources"]
    assert res["rt_after"] == [True, True] and res["lights_after"] == 0, res  # the artist's settings are back
    # every group is that of EEVEE's own GI-off render with the emitter proxies
    assert max(res["vs_own_render"].values()) <= 1e-6, res["vs_own_render"]
    m = res["mean"]
    # the panel lights the box only through its proxy (EEVEE lights nothing from an emissive mesh without GI) ...
    assert m["local"] > 0.05 and m["no_proxy"] < 0.2 * m["local"], m
    # ... and ray tracing + fast GI were off (with them on, the same render's diffuse light differs)
    assert m["gi_on_vs_off"] > 1e-3, m
    # the one render's proxies cast no shadow; asked for shadowed ones, the floor under the box and the ball darkens
    assert res["shadows"]["default"] is False and res["shadows"]["vs_own_shadowed"] <= 1e-6, res["shadows"]
    assert m["shadowed"] < m["local"] and m["darker_shadowed"] > 0.02, m
    # one proxy, facing down; asked for both sides, the ceiling's rim round the panel is lit by the upward one, the
    # rest of the image is the same
    sd = res["sides"]
    assert sd["default"] == "open" and sd["vs_own_both"] <= 1e-6, sd
    assert sd["max_diff"] > 0.01 and sd["frac_diff"] < 0.05, sd
    assert "different one-render renders" in res["both"], res["both"]


def test_a_one_render_fit_trains_scratch_residual_local_networks_on_the_one_renders_groups_only():
    from ssgi.model import channels as ch
    from ssgi.model.errors import UserError
    from ssgi.model.evaluate.fit_report import SHOT_BAR_DB
    from ssgi.model.learn.fit import LADDER
    from ssgi.ssgi_addon.pipeline import fit as pfit
    from ssgi.ssgi_addon.pipeline.bake import one_render_bake_groups

    ladder, target, inputs = pfit.one_render_ladder(None, None, shot=True)
    assert [r[0] for r in ladder] == [r[0] for r in LADDER] and all(r[2]["head"] == "residual_local" for r in ladder)
    assert all(r[2]["widths"] == l[2]["widths"] for r, l in zip(ladder, LADDER))  # the ladder's sizes are kept
    assert target == SHOT_BAR_DB and pfit.one_render_ladder(None, 31.0, shot=True)[1] == 31.0
    spec = ch.parse_spec(inputs)
    baked = one_render_bake_groups("local")
    # every input comes from the views of a local one-render bake, and none from the renders it does without
    assert set(ch.required_groups(spec)) <= set(baked), (spec, baked)
    assert not set(spec) & {"direct", "world", "direct_soft", "emit_direct", "eevee_diffuse", "lit", "scene"}
    assert "gloss" in baked and "eevee_diffuse" not in baked and "eevee_diffuse" in one_render_bake_groups("gi")
    # the lightmap may learn beside the one render's light, the only known light such a frame renders
    from ssgi.model.infer import lightmap
    assert lightmap.known_for(ch.required_groups(spec)) == ("eevee_local",)
    with pytest.raises(UserError, match="--learn-rest"):
        pfit.FitSceneConfig(out="x.pt", blend="x.blend", one_render=True, learn_rest=True).check()
    with pytest.raises(UserError, match="--data"):
        pfit.FitSceneConfig(out="x.pt", data="views", one_render=True).check()


def test_a_local_one_render_bake_needs_its_samples():
    from ssgi.model.errors import UserError
    from ssgi.ssgi_addon.pipeline.bake import BakeConfig

    with pytest.raises(UserError, match="--gi-samples"):
        BakeConfig(out="d", one_render="local").check()
    with pytest.raises(UserError, match="--one-render bogus"):
        BakeConfig(out="d", gi_samples=4, one_render="bogus").check()
    BakeConfig(out="d", gi_samples=4, one_render="local").check()


NODE = r'''
import json, sys
import numpy as np
import bpy
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession

model, blend = sys.argv[1], sys.argv[2]
bpy.ops.wm.open_mainfile(filepath=blend)
sc = bpy.context.scene
sc.eevee.use_raytracing = sc.eevee.use_fast_gi = True
setup_scene(sc, model)
s = RenderSession(sc, frames=[5], model=model, write=False, keep_groups=True)
s.run()
r = s.results[0]
# a model of a one render with shadowed proxies (an older manifest that does not say) gets them
from ssgi.ssgi_addon.blender.passes import recorded_proxy_shadows, recorded_proxy_sides
one = s.predictor.inner.meta["dataset"]["settings"]["eevee"]["one_render"]
old = {"dataset": {"settings": {"eevee": {"one_render": {k: v for k, v in one.items()
                                                         if k not in ("emitter_proxy_shadows", "emitter_proxy_sides")}}}}}
print("RESULT", json.dumps({"renders": sorted(r["t_pass_renders"]), "groups": sorted(r["groups"]),
                            "proxy_shadows": [s.proxy_shadows, recorded_proxy_shadows(old), recorded_proxy_shadows({})],
                            "proxy_sides": [s.proxy_sides, recorded_proxy_sides(old), recorded_proxy_sides({})],
                            "finite": bool(np.isfinite(r["prediction"]).all()), "mean": float(r["prediction"].mean()),
                            "rt_after": [sc.eevee.use_raytracing, sc.eevee.use_fast_gi]}))
'''

@pytest.mark.timeout(1800)
def test_a_one_render_shot_fit_reads_only_the_gi_off_render_and_the_node_renders_it_so(tmp_path):
    blend, model, summary, ck = one_render_shot_fit(tmp_path, "local")
    arch = ck["arch"]
    # a scratch network on the one render's groups (no generic start: its passes are not in the views)
    assert arch["head"] == "residual_local", arch
    assert set(arch["inputs"]) <= {"albedo", "normal", "depth", "emission", "eevee_local", "glow", "surround"}, arch
    assert {"albedo", "eevee_local"} <= set(arch["inputs"]), arch
    views = next((model.parent / "shot.fit").glob("views-*/manifest.json"))
    m = json.loads(views.read_text())
    one = m["settings"]["eevee"]["one_render"]
    assert one["kind"] == "local" and one["raytracing"] is False and one["emitter_proxies"] is True, one
    assert one["emitter_proxy_shadows"] is False, one  # recorded: the node renders the model's frames so
    assert one["emitter_proxy_sides"] == "open", one  # (and only the sides of the panel facing open space)
    held = {g["name"] for g in m["channel_spec"] if "channels" in g}
    assert {"eevee_local", "rest", "gloss"} <= held and not held & {"world", "direct_soft", "emit_direct"}, held
    # the withheld frames are scored against EEVEE's own render too, and the fitted image beats it there
    w = summary["withheld"]["methods"]
    assert {"fitted", "eevee_gi", "cycles_1spp_oidn"} <= set(w), w.keys()
    assert w["fitted"]["psnr"] > w["eevee_gi"]["psnr"], (w["fitted"]["psnr"], w["eevee_gi"]["psnr"])
    # the node: one EEVEE render a frame, the artist's ray tracing and fast GI back afterwards
    p = run_py(NODE, str(model), str(blend), timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert set(res["renders"]) <= {"rest", "surround"} and "rest" in res["renders"], res["renders"]
    assert not set(res["groups"]) & {"direct", "world", "direct_soft", "emit_direct", "eevee"}, res["groups"]
    assert res["finite"] and res["mean"] > 0.01 and res["rt_after"] == [True, True], res
    assert res["proxy_shadows"] == [False, True, None], res["proxy_shadows"]
    # older bakes recorded no sides and had a proxy on both: the node renders their frames so
    assert res["proxy_sides"] == ["open", "both", None], res["proxy_sides"]
