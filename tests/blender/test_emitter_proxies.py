"""The rest render's emitter proxies (passes.render_rest(proxies=True), direct_light.emitter_proxies), on real Blender:
the artist test set's Cornell box lit only by an emissive ceiling panel, with a mirror ball, at 64x36. EEVEE lights nothing
from an emissive mesh off screen, so its mirror ball reflected dark walls where Cycles' shows them lit; with an
area light standing in for the panel during the rest render, the ball comes closer to Cycles'. The proxies are
gone after the render, the render path's rest is made with them, EEVEE's own render (``proxies=False``) and
scenes without a planar emitter are unchanged."""
from __future__ import annotations

import json

from ..conftest import cornell_script, run_py

CODE = cornell_script(4) + r'''
from bpy_extras.object_utils import world_to_camera_view
from ssgi.ssgi_addon.blender import passes, direct_light
W, H = 64, 36

def patch(img, name):
    """the mean over the object's projected bounding box"""
    o = bpy.data.objects[name]
    vs = [world_to_camera_view(sc, sc.camera, o.matrix_world @ __import__("mathutils").Vector(c)) for c in o.bound_box]
    ys = [int(round((1 - v.y) * H - 0.5)) for v in vs]
    xs = [int(round(v.x * W - 0.5)) for v in vs]
    return float(img[max(0, min(ys)):min(H, max(ys) + 1), max(0, min(xs)):min(W, max(xs) + 1), :3].mean())

res = {"emitters": [o.name for o, *_ in direct_light.planar_emitters(sc)]}
n_lights, n_objects = len(bpy.data.lights), len(bpy.data.objects)
plain = passes.render_rest(sc)[0]
proxied = passes.render_rest(sc, proxies=True)[0]
res["left_behind"] = [len(bpy.data.lights) - n_lights, len(bpy.data.objects) - n_objects]
with direct_light.emitter_proxies(sc) as made:
    res["proxies"] = [(o.data.type, round(o.data.energy, 3), round(o.data.size, 3), round(o.data.size_y, 3),
                       [round(v, 3) for v in (o.matrix_world.to_3x3() @ __import__("mathutils").Vector((0, 0, -1)))])
                      for o in made]
# the panel hangs 2 mm under the ceiling: only its downward side faces open space
res["open_sides"] = direct_light.open_sides(sc, bpy.data.objects["emissive_panel"])
with direct_light.emitter_proxies(sc, sides="open") as made:
    res["open_proxies"] = [[round(v, 3) for v in (o.matrix_world.to_3x3() @ __import__("mathutils").Vector((0, 0, -1)))]
                           for o in made]
res["left_behind_open"] = [len(bpy.data.lights) - n_lights, len(bpy.data.objects) - n_objects]
# lifted 0.3 m off the ceiling it faces open space both ways
bpy.data.objects["emissive_panel"].location.z -= 0.3
bpy.context.view_layer.update()
res["open_sides_lowered"] = direct_light.open_sides(sc, bpy.data.objects["emissive_panel"])
bpy.data.objects["emissive_panel"].location.z += 0.3
bpy.context.view_layer.update()
# with a little thickness towards the room (still planar) its own faces do not close its front
sol = bpy.data.objects["emissive_panel"].modifiers.new("thick", "SOLIDIFY")
sol.thickness, sol.offset = 0.0004, 1.0
bpy.context.view_layer.update()
res["thick"] = [[o.name for o, *_ in direct_light.planar_emitters(sc)],
                direct_light.open_sides(sc, bpy.data.objects["emissive_panel"])]
bpy.data.objects["emissive_panel"].modifiers.remove(sol)
bpy.context.view_layer.update()
g = passes.render_gbuffer(sc, ("albedo", "rest"), samples=4, rest_samples=4)
ref = passes.render_cycles(sc, 64, seed=3, denoise=True, groups=("ref", "ref_diffuse"))
cyc_rest = ref["ref"] - ref["ref_diffuse"]
res["ball"] = {"plain": patch(plain, "mirror_ball"), "proxied": patch(proxied, "mirror_ball"),
               "cycles": patch(cyc_rest, "mirror_ball")}
res["image_error"] = {"plain": float(np.abs(plain - cyc_rest).mean()), "proxied": float(np.abs(proxied - cyc_rest).mean())}
res["path_vs_proxied"] = float(np.abs(g["rest"] - proxied).max())
res["path_vs_plain"] = float(np.abs(g["rest"] - plain).max())
# a scene without a planar emitter: the same render either way
bpy.data.objects["emissive_panel"].hide_render = True
res["no_emitter"] = direct_light.planar_emitters(sc)
res["no_emitter_diff"] = float(np.abs(passes.render_rest(sc, proxies=True)[0] - passes.render_rest(sc)[0]).max())
print("RESULT", json.dumps(res))
'''


def test_the_rest_render_lights_what_a_planar_emitter_lights_and_leaves_the_scene_as_it_was():
    p = run_py(CODE, timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["emitters"] == ["emissive_panel"], res
    assert res["left_behind"] == [0, 0], res
    # two rectangles of the panel's size (0.5 x 0.4), power pi x 20 x 0.2, one facing down (into the box), one up
    assert len(res["proxies"]) == 2, res["proxies"]
    for kind, energy, sx, sy, _d in res["proxies"]:
        assert kind == "AREA" and abs(energy - 3.14159 * 20 * 0.2) < 0.01 and (sx, sy) == (0.5, 0.4), res["proxies"]
    assert sorted(round(p[4][2]) for p in res["proxies"]) == [-1, 1], res["proxies"]
    # with sides="open" one proxy, facing down into the box (the side 2 mm under the ceiling gets none)
    assert res["open_sides"] == [True, False] and res["open_sides_lowered"] == [True, True], res
    assert [round(v) for v in res["open_proxies"][0]] == [0, 0, -1] and len(res["open_proxies"]) == 1, res
    assert res["left_behind_open"] == [0, 0], res
    assert res["thick"] == [["emissive_panel"], [True, False]], res["thick"]
    b = res["ball"]
    # the mirror ball: brighter with the proxies, and closer to Cycles' non-diffuse light there
    assert b["proxied"] > 1.5 * b["plain"], b
    assert abs(b["proxied"] - b["cycles"]) < 0.7 * abs(b["plain"] - b["cycles"]), b
    e = res["image_error"]  # and the whole rest: closer to Cycles' (mean absolute difference)
    assert e["proxied"] < 0.85 * e["plain"], e  # measured 0.011 against 0.0143
    # the render path's rest is the proxied render (within EEVEE's run-to-run noise), not EEVEE's own
    assert res["path_vs_proxied"] < 0.2 * res["path_vs_plain"], res
    assert res["no_emitter"] == [] and res["no_emitter_diff"] < 1e-6, res
