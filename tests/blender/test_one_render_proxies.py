"""The one render of one-render models (docs/one_render.md): ONE EEVEE render with ray tracing and fast GI switched
off and an area light standing in for each planar emitter, casting no shadow and only on the sides of an emitter that
face open space (``passes.ONE_RENDER_SETTINGS``; a model baked with other proxies gets those,
``passes.recorded_proxy_options``). Its Diffuse Direct pass is ``eevee_local`` (what one-render bakes store beside
its Combined image), and albedo, normal, depth, emission, rest and gloss come from it too. Real EEVEE at tiny sizes:
the pass call makes one render with GI off and proxies on and puts the artist's settings back."""
from __future__ import annotations

import json

from ..conftest import cornell_script, run_py

PASSES = cornell_script(2) + r'''
from ssgi.ssgi_addon.blender import passes
sc.eevee.use_raytracing = sc.eevee.use_fast_gi = True   # the artist's: the GI-off call switches both off
n_lights = len(bpy.data.lights)
groups = ("albedo", "normal", "depth", "emission", "eevee_local", "surround", "rest", "gloss")
one = passes.render_gbuffer(sc, groups, samples=2, rest_samples=2)
res = {"renders": sorted(passes.last_timings), "sources": dict(passes.last_sources),
       "rt_after": [sc.eevee.use_raytracing, sc.eevee.use_fast_gi], "lights_after": len(bpy.data.lights) - n_lights}
shadows, sides = passes.ONE_RENDER_SETTINGS["proxy_shadows"], passes.ONE_RENDER_SETTINGS["proxy_sides"]
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
# a model's recorded proxies: a bake that recorded no shadows or sides had shadowed proxies on both sides; a model
# without a one render gets none
old = {"dataset": {"settings": {"eevee": {"one_render": {"emitter_proxies": True}}}}}
res["recorded"] = [passes.recorded_proxy_options(old), passes.recorded_proxy_options({})]
print("RESULT", json.dumps(res))
'''


def test_the_one_render_call_makes_one_render_with_gi_off_and_proxies_on_and_puts_them_back():
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
    assert res["recorded"] == [{"proxy_shadows": True, "proxy_sides": "both", "proxy_shapes": "planar"}, {}], res["recorded"]
