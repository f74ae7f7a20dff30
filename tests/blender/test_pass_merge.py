"""The render path reads albedo, normal, depth and emission from the artist-settings render
(the one that gives ``rest``) instead of the direct-only G-buffer render (passes.render_gbuffer ``merge``).
On a tiny scene with a lamp, an emissive panel, a sky (a gradient world), metal and glass, real EEVEE at
64x36 and 2 samples: every group of the merged call equals the separate renders' within 1e-6 (measured: exactly
equal), the direct-only render is still made for ``direct`` and ``eevee``, and with the rest render at other
samples nothing is merged (its anti-aliasing would differ)."""
from __future__ import annotations

import json

from ..conftest import ROOT, run_py

# the tiny scene under a gradient sky
TINY_SKY_SCENE = r'''
import json, sys
import numpy as np
import bpy
sys.path.insert(0, str(ROOT))
from scenes import artist as artist_scenes
from ssgi.ssgi_addon.blender import passes

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
artist_scenes.tiny_material_scene(sc)
artist_scenes.world_gradient(sc, (0.1, 0.09, 0.08), (0.6, 0.7, 0.8), (0.2, 0.35, 0.8), strength=1.0)
'''

CODE = TINY_SKY_SCENE + r'''
groups = ("albedo", "normal", "depth", "direct", "emission", "world", "eevee", "rest")
res = {}
runs = {"separate": dict(merge=False), "merged": dict(merge=True)}
out = {}
for name, kw in runs.items():
    out[name] = passes.render_gbuffer(sc, groups, samples=2, rest_samples=2, **kw)
    res[name + "_renders"] = sorted(passes.last_timings)
    res[name + "_sources"] = dict(passes.last_sources)
out["other"] = passes.render_gbuffer(sc, ("albedo", "direct", "rest"), samples=2, rest_samples=1, merge=True)
res["other_renders"] = sorted(passes.last_timings)
res["other_sources"] = dict(passes.last_sources)
a, b = out["separate"], out["merged"]
res["max_abs"] = {g: float(np.abs(a[g] - b[g]).max()) for g in groups}
res["mean"] = {g: float(np.abs(a[g]).mean()) for g in groups}
res["albedo_other_vs_1"] = float(np.abs(out["other"]["albedo"] - a["albedo"]).max())
emis = a["emission"].max(axis=-1) > 0.5
geo = a["depth"][..., 0] < 0.999 * sc.camera.data.clip_end
res["emissive_px"], res["sky_px"] = int(emis.sum()), int((~geo).sum())
res["world_on_geometry"] = float(a["world"][geo].mean())
print("RESULT", json.dumps(res))
'''

TOL = 1e-6


def test_merged_render_gives_the_separate_renders_groups(tmp_path):
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + CODE, timeout=900)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    # the scene has what the merge must survive: an emitter on screen, sky pixels, world light on surfaces
    assert res["emissive_px"] > 5 and res["sky_px"] > 20 and res["world_on_geometry"] > 0.05, res
    for g, d in res["max_abs"].items():
        assert res["mean"][g] > 0 or g == "emission", (g, res["mean"])  # nothing compared is all zeros
        assert d <= TOL, (g, d, res["max_abs"])
    # the merged call still renders the direct-only pass (direct, eevee) and the world pass, and the rest render
    assert res["merged_renders"] == ["raster", "rest", "world"], res["merged_renders"]
    assert res["separate_renders"] == ["raster", "rest", "world"], res["separate_renders"]
    shared = ("albedo", "normal", "depth", "emission")
    assert all(res["merged_sources"][g] == "rest" for g in shared), res["merged_sources"]
    assert all(res["separate_sources"][g] == "raster" for g in shared), res["separate_sources"]
    assert res["merged_sources"]["direct"] == res["merged_sources"]["eevee"] == "raster", res["merged_sources"]
    # rest at other samples: albedo from the 2-sample direct-only render, i.e. as the separate call's
    assert res["other_sources"]["albedo"] == "raster" and res["albedo_other_vs_1"] <= TOL, res


def test_the_world_pass_alone_puts_the_artists_settings_back():
    code = """
    import json
    import bpy
    from ssgi.ssgi_addon.blender import passes, room
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = room.build_room(1, bpy.context.scene, mode="artist")   # an open room under a sky: the pass renders
    passes.set_resolution(scene, 32, 18)
    ee = scene.eevee
    ee.use_raytracing, ee.use_fast_gi, ee.taa_render_samples = True, True, 7
    w = passes.render_world(scene, samples=1)
    print("JSON" + json.dumps(dict(rt=ee.use_raytracing, gi=ee.use_fast_gi, n=ee.taa_render_samples,
                                   lit=float(w.max()), world=room.room_params(1, "artist")["world"]["type"])))
    """
    out = json.loads(run_py(code, timeout=300).stdout.split("JSON", 1)[1])
    assert out["world"] != "black" and out["lit"] > 0  # the pass was rendered
    assert (out["rt"], out["gi"], out["n"]) == (True, True, 7)


def test_eevee_gi_of_the_report_lights_a_lamp_lit_room_without_a_gbuffer_render_before():
    code = """
    import json
    import bpy, numpy as np
    from ssgi.ssgi_addon.blender import passes, room
    from ssgi.ssgi_addon.pipeline.report_run import render_eevee_gi
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = room.build_room(3, bpy.context.scene)     # a closed diffuse room lit by lamps
    passes.set_resolution(scene, 32, 18)
    gi = render_eevee_gi(scene, "default", 1)           # first: nothing set up by another render
    d = passes.render_gbuffer(scene, ("albedo", "direct", "normal", "depth"))
    print("JSON" + json.dumps(dict(gi=float(gi.mean()), lit=float((d["albedo"] * d["direct"]).mean()))))
    """
    out = json.loads(run_py(code, timeout=300).stdout.split("JSON", 1)[1])
    assert out["lit"] > 0.01 and out["gi"] > 0.8 * out["lit"]  # GI adds bounce light to the lamps' direct light


def test_the_rest_render_culls_no_lamp_and_puts_the_artists_threshold_back():
    """The artist test set's studio (two softboxes) at Blender's default light threshold 0.01 and no cutoff
    distances: EEVEE culls enough of the lamps' light that its own render is 16 % darker (320x180). The rest
    render lights it as the G-buffer does (threshold 0, cutoff distances set): its Combined equals a render made
    so by hand, is brighter than the artist-threshold render, and the artist's settings come back."""
    code = """
    import json, sys
    import bpy, numpy as np
    sys.path.insert(0, str(ROOT))
    from scenes import artist as artist_scenes
    from ssgi.ssgi_addon.blender import passes
    scene = artist_scenes.build("studio", size=(64, 36))
    scene.eevee.taa_render_samples = 1
    lamps = [o.data for o in scene.objects if o.type == "LIGHT"]
    before = (scene.eevee.light_threshold, [l.use_custom_distance for l in lamps])
    rest, comb = passes.render_rest(scene)
    after = (scene.eevee.light_threshold, [l.use_custom_distance for l in lamps])
    def combined():
        p = passes._render(scene)["Combined"]
        return np.stack([p[c] for c in "RGB"], axis=-1)
    own = combined()                                   # the scene as its own settings render it
    scene.eevee.light_threshold = 0.0
    passes.no_light_culled(scene)
    unculled = combined()
    print("JSON" + json.dumps(dict(before=before, after=after, rest=float(comb[..., :3].mean()), own=float(own.mean()),
                                   unculled=float(unculled.mean()),
                                   diff=float(np.abs(comb[..., :3] - unculled).max()))))
    """
    code = f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + __import__("textwrap").dedent(code)
    out = json.loads(run_py(code, timeout=300).stdout.split("JSON", 1)[1])
    assert abs(out["before"][0] - 0.01) < 1e-6 and not any(out["before"][1]), out  # the artist's defaults
    assert out["after"] == out["before"], out                                    # put back
    assert out["diff"] <= 1e-5, out                                              # lit with no lamp culled
    assert out["own"] < 0.95 * out["rest"], out                                  # culling matters in this scene


KEEP_CODE = TINY_SKY_SCENE + r'''
import glob, os, tempfile
mine = lambda: sorted(glob.glob(os.path.join(tempfile.gettempdir(), f".ssgi-*.{os.getpid()}.tmp")))
res = {}
with passes.keep_render_file() as kept:
    g = passes.render_gbuffer(sc, ("albedo", "normal", "depth", "direct", "rest"), samples=2, rest_samples=2)
    res["renders"] = sorted(passes.last_timings)
    res["inside"] = mine()
res["kept"] = kept.path
res["after"] = mine()
import OpenEXR
with OpenEXR.File(kept.path) as f:
    res["compression"] = str(f.header(0)["compression"])
back = passes.read_multilayer(kept.path)
res["albedo_vs_file"] = float(np.abs(np.stack([back["Diffuse Color"][c] for c in "RGB"], -1) - g["albedo"]).max())
os.unlink(kept.path)
try:
    with passes.keep_render_file() as kept2:
        passes.render_gbuffer(sc, ("albedo", "rest"), samples=1, rest_samples=1)
        res["second"] = kept2.path
        raise KeyError("stop")
except KeyError:
    pass
res["after_error"] = mine()
passes.render_gbuffer(sc, ("albedo", "rest"), samples=1, rest_samples=1)
res["outside"] = mine()
print("RESULT", json.dumps(res))
'''


def test_the_render_path_keeps_the_last_renders_file_for_the_compositor_and_no_other():
    """keep_render_file (the compositor's stand-in): of a call that renders twice (direct-only, then
    the artist-settings render) exactly one read-back file is left, the last render's (its albedo is the group's),
    uncompressed (passes.SCRATCH_EXR_CODEC); an exception inside removes it; outside, no file stays."""
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + KEEP_CODE, timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["renders"] == ["raster", "rest"], res
    assert res["inside"] == res["after"] == [res["kept"]], res  # one file: the first render's was removed
    assert "ssgi-render-" in res["kept"], res
    assert res["albedo_vs_file"] == 0.0, res  # the artist-settings render's passes (albedo comes from it)
    assert "NO_COMPRESSION" in res["compression"], res
    assert res["second"] and res["after_error"] == [] and res["outside"] == [], res


SHADOW_CODE = TINY_SKY_SCENE + r'''
ee = sc.eevee
res = {"lamps": [o.name for o in sc.objects if o.type == "LIGHT"]}
res["with_lamp"] = passes.casts_no_shadow(sc)
for o in sc.objects:
    if o.type == "LIGHT":
        o.data.use_shadow = False
res["lamp_unshadowed"] = passes.casts_no_shadow(sc)           # the gradient sky's sun still may
sc.world.use_sun_shadow = False
res["no_sun_shadow"] = passes.casts_no_shadow(sc)
groups = ("albedo", "normal", "depth", "emission", "rest")
out = {}
for skip in (False, True):
    # (no emitter proxies: the render path's rest render stands shadowed area lights in for the tiny panel)
    out[skip] = passes.render_gbuffer(sc, groups, samples=2, rest_samples=2, proxies=False, skip_unused_shadows=skip)
    res[f"skipped_{skip}"] = passes.last_render["shadows_skipped"]
    res[f"use_shadows_after_{skip}"] = ee.use_shadows
res["max_abs"] = {g: float(np.abs(out[True][g] - out[False][g]).max()) for g in groups + ("beauty",)}
res["mean_beauty"] = float(out[True]["beauty"][..., :3].mean())
for o in sc.objects:                                          # a lamp that casts a shadow: nothing is skipped
    if o.type == "LIGHT":
        o.data.use_shadow = True
passes.render_gbuffer(sc, ("albedo", "rest"), samples=1, rest_samples=1, proxies=False)
res["skipped_with_shadowed_lamp"] = passes.last_render["shadows_skipped"]
print("RESULT", json.dumps(res))
'''


def test_a_render_in_which_nothing_casts_a_shadow_skips_eevees_shadows_and_gives_the_same_image():
    """passes.casts_no_shadow / render_gbuffer's skip_unused_shadows: the tiny scene's lamp casts a shadow; unshadowed, the
    gradient sky's extracted sun still may; with that off nothing can, and the render path's render is made with
    EEVEE's shadows off: every group and the image equal the shadows-on render's exactly, and the artist's setting
    is back afterwards. With the lamp's shadow back on, nothing is skipped."""
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + SHADOW_CODE, timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["lamps"], res
    assert (res["with_lamp"], res["lamp_unshadowed"], res["no_sun_shadow"]) == (False, False, True), res
    assert (res["skipped_False"], res["skipped_True"]) == (False, True), res
    assert res["use_shadows_after_False"] is True and res["use_shadows_after_True"] is True, res
    assert res["mean_beauty"] > 0.01, res
    assert all(d == 0.0 for d in res["max_abs"].values()), res
    assert res["skipped_with_shadowed_lamp"] is False, res


EMIT_CODE = r'''
import json, sys
import numpy as np
import bpy
sys.path.insert(0, str(ROOT))
from scenes import artist as artist_scenes
from ssgi.ssgi_addon.blender import direct_light, passes

res = {}
sc = artist_scenes.build("closed_room", size=(48, 27))
sc.eevee.taa_render_samples = 2
res["closed_may_emit"] = direct_light.materials_may_emit()
groups = ("albedo", "normal", "depth", "emission", "eevee_combined")
out = {}
sc.view_layers[0].use_pass_emit = True  # as compositor.setup_scene leaves it for a model that reads emission
for skip in (True, False):
    g = passes.render_gbuffer(sc, groups, skip_empty_emission=skip)
    res[f"skipped_{skip}"] = passes.last_render["emission_skipped"]
    res[f"emit_flag_after_{skip}"] = sc.view_layers[0].use_pass_emit
    out[skip] = g
# the artist's compositor reads the Emission pass: it is written (the render path's stand-in is the render's file)
tree = bpy.data.node_groups.new("comp", "CompositorNodeTree")
sc.compositing_node_group = tree
rl = tree.nodes.new("CompositorNodeRLayers")
mix = tree.nodes.new("ShaderNodeMix")
mix.data_type = "RGBA"
tree.links.new(rl.outputs["Emission"], mix.inputs["A"] if "A" in mix.inputs else mix.inputs[6])
passes.render_gbuffer(sc, groups)
res["skipped_tree_reads"] = passes.last_render["emission_skipped"]
sc.compositing_node_group = None
res["max_abs"] = {k: float(np.abs(out[True][k] - out[False][k]).max()) for k in groups}
res["emission_max"] = float(np.abs(out[False]["emission"]).max())
res["shape"] = list(out[True]["emission"].shape) == list(out[False]["emission"].shape)
res["mean_beauty"] = float(out[True]["eevee_combined"].mean())
# what may write the Emission pass, one material at a time on the crate
crate = bpy.data.objects["crate"]
def with_material(build):
    m = bpy.data.materials.new("probe")
    build(m.node_tree)
    crate.material_slots[0].material = m
    r = direct_light.materials_may_emit()
    crate.material_slots[0].material = bpy.data.materials["crate_blue"]
    bpy.data.materials.remove(m)
    return r
def principled_strength(nt, v=2.0):
    nt.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = v
def principled_linked(nt):
    t = nt.nodes.new("ShaderNodeTexNoise")
    nt.links.new(t.outputs["Fac"], nt.nodes["Principled BSDF"].inputs["Emission Strength"])
def specular(nt):
    s = nt.nodes.new("ShaderNodeEeveeSpecular")
    s.inputs["Emissive Color"].default_value = (0.3, 0.2, 0.1, 1.0)
    nt.links.new(s.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
def grouped(emitting):
    def build(nt):
        grp = bpy.data.node_groups.new("inner", "ShaderNodeTree")
        grp.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
        e = grp.nodes.new("ShaderNodeEmission" if emitting else "ShaderNodeBsdfDiffuse")
        if emitting:
            e.inputs["Strength"].default_value = 3.0
        o = grp.nodes.new("NodeGroupOutput")
        grp.links.new(e.outputs[0], o.inputs[0])
        n = nt.nodes.new("ShaderNodeGroup")
        n.node_tree = grp
        nt.links.new(n.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    return build
res["probes"] = {"principled_0": with_material(lambda nt: principled_strength(nt, 0.0)),
                 "principled_2": with_material(principled_strength),
                 "principled_linked": with_material(principled_linked),
                 "specular_emissive": with_material(specular),
                 "group_emission": with_material(grouped(True)),
                 "group_diffuse": with_material(grouped(False))}
unused = bpy.data.materials.new("unused_lamp")
unused.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 5.0
res["unused_emitter"] = direct_light.materials_may_emit()
# an emitter in the file: the pass is written
crate.material_slots[0].material = unused
g = passes.render_gbuffer(sc, groups)
res["emitter_skipped"] = passes.last_render["emission_skipped"]
res["emitter_emission_max"] = float(g["emission"].max())
print("RESULT", json.dumps(res))
'''


def test_where_no_material_can_emit_the_render_path_leaves_the_emission_pass_out_and_gives_the_same_groups():
    """render_gbuffer's skip_empty_emission: in the artist test set's closed room (diffuse Principled materials, a
    point lamp, a black world) no used material can emit (direct_light.materials_may_emit), so the one render
    leaves the Emission pass out: every group, the image and the zero emission equal those of the render that writes
    the pass (whose Emission is black to the bit), and the artist's pass flag is back afterwards. Emission Strength 0
    does not count as an emitter; a Principled emission strength above 0 or linked, a Specular BSDF's Emissive Color
    and an Emission shader inside a node group do; an unused emissive material does not, and once a mesh uses it the
    pass is written and is bright; so it is where the artist's compositor reads it from a Render Layers node."""
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + EMIT_CODE, timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["closed_may_emit"] is False, res
    assert (res["skipped_True"], res["skipped_False"]) == (True, False), res
    assert res["emit_flag_after_True"] is True and res["emit_flag_after_False"] is True, res
    assert res["skipped_tree_reads"] is False, res
    assert res["shape"] and res["mean_beauty"] > 0.01, res
    assert res["emission_max"] == 0.0, res
    assert all(d == 0.0 for d in res["max_abs"].values()), res
    assert res["probes"] == {"principled_0": False, "principled_2": True, "principled_linked": True,
                             "specular_emissive": True, "group_emission": True, "group_diffuse": False}, res
    assert res["unused_emitter"] is False, res
    assert res["emitter_skipped"] is False and res["emitter_emission_max"] > 0.5, res


NORMAL_CODE = r'''
import json, sys
import numpy as np
import bpy
sys.path.insert(0, str(ROOT))
from scenes import artist as artist_scenes
from ssgi.ssgi_addon.blender import passes
from ssgi.model.images import geometry_mask

res = {}
sc = artist_scenes.build("closed_room", size=(96, 54))
sc.eevee.taa_render_samples = 2
sc.view_layers[0].use_pass_normal = True  # as compositor.setup_scene leaves it
groups = ("albedo", "normal", "depth", "eevee_combined")
d = passes.render_gbuffer(sc, groups)
res["default_derived"] = passes.last_render["normals_from_depth"]
res["flag_after"] = sc.view_layers[0].use_pass_normal
p = passes.render_gbuffer(sc, groups, normals="pass")
res["pass_derived"] = passes.last_render["normals_from_depth"]
geo = geometry_mask(p["depth"], p["normal"])
cos = np.clip(np.einsum("...i,...i->...", d["normal"], p["normal"]), -1, 1)[geo]
ang = np.degrees(np.arccos(cos))
res["angle_median"], res["angle_p90"] = float(np.median(ang)), float(np.percentile(ang, 90))
res["unit"] = float(np.abs(np.linalg.norm(d["normal"][geo], axis=-1) - 1).max())
res["zero_outside"] = bool(np.all(d["normal"][~geometry_mask(d["depth"])] == 0))
res["same"] = {g: float(np.abs(d[g] - p[g]).max()) for g in ("albedo", "depth", "eevee_combined")}
# a diffuse-part model's groups (no one render): EEVEE's Normal pass, whatever the default
passes.render_gbuffer(sc, ("albedo", "normal", "depth"))
res["raster_derived"] = passes.last_render["normals_from_depth"]
try:
    passes.render_gbuffer(sc, groups, normals="smooth")
except ValueError as e:
    res["bad"] = str(e)
# where the world shows (EEVEE's Z pass: about the clip end), the derived normal is zero, as the pass's
ext = artist_scenes.build("exterior", size=(96, 54))
ext.eevee.taa_render_samples = 2
de, pe = passes.render_gbuffer(ext, groups), passes.render_gbuffer(ext, groups, normals="pass")
world = ~(np.abs(pe["normal"]).sum(-1) > 0.5)
dzero = ~(np.abs(de["normal"]).sum(-1) > 0.5)
res["world_px"], res["world_derived_nonzero"] = int(world.sum()), int((world & ~dzero).sum())
res["geometry_derived_zero"] = int((~world & dzero).sum())
print("RESULT", json.dumps(res))
'''


def test_a_one_render_frame_takes_its_normals_from_the_depth_and_they_are_the_passs_on_flat_surfaces():
    """passes.render_gbuffer's normals: a one-render model's frame writes no Normal pass (its flag, on as
    setup_scene leaves it, is off for the render and back after it); its normals, from the Z pass, are unit length on
    geometry, zero where nothing was hit (the exterior's sky, where the Z pass holds the clip end), and agree with EEVEE's Normal pass (normals="pass", what a bake stores) to
    a median under 1 degree in the closed room (walls, a crate, a ball, a column); every other group is the same. A
    model without a one render keeps the pass; an unknown source is refused."""
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + NORMAL_CODE, timeout=600)
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert res["default_derived"] is True and res["pass_derived"] is False and res["raster_derived"] is False, res
    assert res["flag_after"] is True, res
    assert res["angle_median"] < 1.0 and res["angle_p90"] < 10.0, res
    assert res["unit"] < 1e-4 and res["zero_outside"], res
    # the exterior's sky: zero derived normals exactly where the pass has none (but for a few anti-aliased
    # silhouette pixels, whose Z is the surface's and whose pass normal is a blend)
    assert res["world_px"] > 500 and res["world_derived_nonzero"] == 0, res
    assert res["geometry_derived_zero"] < 0.02 * (96 * 54 - res["world_px"]), res
    assert all(v == 0.0 for v in res["same"].values()), res
    assert "'pass' or 'depth'" in res["bad"], res
