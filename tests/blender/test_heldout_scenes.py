"""The held-out set (scenes/heldout.py) and the tuning / held-out split (scenes/__init__.py): every scene builds,
saves and reopens with its render settings, two builds are the same, each holds what it promises (the bathroom's
mirror, the product shot's one area light); tiny Cycles renders (64x36, 4 spp): each scene is lit, the neon room
only by its emitters, the kitchen only through its window (by the sun and the sky)."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from ..conftest import ROOT, run_py

HELD_OUT = ("kitchen", "neon_room", "product_shot", "furnished_room", "staircase", "bathroom")

_DESCRIBE = """
import json, sys
import bpy
import scenes
from scenes import heldout as H
from ssgi.ssgi_addon.blender import blendfile

def describe(scene):
    objs = {}
    for o in sorted(scene.objects, key=lambda o: o.name):
        d = dict(type=o.type, matrix=[round(v, 6) for row in o.matrix_world for v in row])
        if o.type == "MESH":
            m = o.active_material
            p = m.node_tree.nodes["Principled BSDF"]
            d.update(faces=len(o.data.polygons), mat=m.name, metallic=p.inputs["Metallic"].default_value,
                     roughness=p.inputs["Roughness"].default_value,
                     strength=p.inputs["Emission Strength"].default_value)
        elif o.type == "LIGHT":
            d.update(kind=o.data.type, energy=o.data.energy, size=[getattr(o.data, "size", 0), getattr(o.data, "size_y", 0)])
        objs[o.name] = d
    r, ee = scene.render, scene.eevee
    return dict(objects=objs, camera=scene.camera.name if scene.camera else None, engine=r.engine,
                size=[r.resolution_x, r.resolution_y, r.resolution_percentage], raytracing=ee.use_raytracing,
                fast_gi=ee.use_fast_gi, samples=ee.taa_render_samples, view=scene.view_settings.view_transform,
                frame=scene.frame_current, world=list(scene.world.color) if scene.world else None)

out = dict(split=dict(tuning=list(scenes.TUNING), held_out=list(scenes.HELD_OUT), names=list(H.NAMES),
                      builders={n: scenes.builder(n).__name__ for n in scenes.TUNING + scenes.HELD_OUT}))
from scenes import artist
out["split"]["artist_names"] = list(artist.NAMES)
for name in H.NAMES:
    first = describe(H.build(name, (64, 36)))
    second = describe(H.build(name, (64, 36)))
    path = sys.argv[1] + "/" + name + ".blend"
    H.save(bpy.context.scene, path)
    out[name] = dict(first=first, second=second, reopened=describe(blendfile.open_blend(path)))
print("JSON" + json.dumps(out))
"""

# Each scene at 64x36, 4 spp: its mean lit, then with its lights switched off (the neon room's emission strengths,
# the kitchen's sun and sky strength) to show where its light comes from.
_RENDER = """
import json
import bpy
from scenes import heldout as H

def off(name):
    if name == "neon_room":
        for m in bpy.data.materials:
            m.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 0.0
    elif name == "kitchen":
        bpy.data.objects["sun"].data.energy = 0.0
        bpy.context.scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    else:
        return False
    return True

out = {}
for name in H.NAMES:
    scene = H.build(name, (64, 36))
    lit, _ = H.art.render_cycles(scene, 4)
    out[name] = dict(lit=float(lit.mean()))
    if off(name):
        dark, _ = H.art.render_cycles(scene, 4)
        out[name]["off"] = float(dark.mean())
print("JSON" + json.dumps(out))
"""


def _json(p) -> dict:
    return json.loads([ln for ln in p.stdout.splitlines() if ln.startswith("JSON")][-1][4:])


@pytest.fixture(scope="module")
def described(tmp_path_factory):
    d = tmp_path_factory.mktemp("heldout")
    return _json(run_py(_DESCRIBE, str(d), timeout=300)), d


def test_import_scenes_is_bpy_free_and_names_the_split():
    code = ("import sys, scenes; assert 'bpy' not in sys.modules; "
            "print(scenes.TUNING, scenes.HELD_OUT); scenes.builder('no_such_scene')")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert "no such scene" in p.stderr and "bpy" not in p.stdout, p.stderr[-2000:]


def test_the_split_is_the_artist_set_and_the_held_out_set(described):
    split = described[0]["split"]
    assert tuple(split["tuning"]) == tuple(split["artist_names"])
    assert tuple(split["held_out"]) == tuple(split["names"]) == HELD_OUT
    assert not set(split["tuning"]) & set(split["held_out"])
    assert {n: m.split(".")[-1] for n, m in split["builders"].items()} == {
        **{n: "artist" for n in split["tuning"]}, **{n: "heldout" for n in HELD_OUT}}


def test_each_scene_builds_saves_and_reopens_with_its_render_settings(described):
    out, d = described
    for name in HELD_OUT:
        assert (d / f"{name}.blend").stat().st_size > 10_000, name
        assert not list(d.glob(f".{name}*")), "a temporary file was left behind"
        s = out[name]["reopened"]
        assert s["objects"] == out[name]["first"]["objects"], name
        assert s["camera"] and [o["type"] for o in s["objects"].values()].count("CAMERA") == 1, name
        assert (s["engine"], s["raytracing"], s["fast_gi"], s["samples"]) == ("BLENDER_EEVEE", True, True, 16), name
        assert s["view"] == "Standard" and s["size"] == [64, 36, 100] and s["frame"] == 1, name
        meshes = [o for o in s["objects"].values() if o["type"] == "MESH"]
        assert len(meshes) >= 4 and sum(o["faces"] for o in meshes) < 10_000, name


def test_two_builds_are_the_same(described):
    out, _ = described
    for name in HELD_OUT:
        assert out[name]["first"] == out[name]["second"], name


def test_each_scene_holds_its_lights_and_materials(described):
    out = described[0]
    scene = {n: out[n]["reopened"]["objects"] for n in HELD_OUT}
    lights = {n: sorted(o["kind"] for o in objs.values() if o["type"] == "LIGHT") for n, objs in scene.items()}
    emitters = {n: sorted(k for k, o in objs.items() if o["type"] == "MESH" and o["strength"] > 0)
                for n, objs in scene.items()}
    assert lights["kitchen"] == ["SUN"] and lights["staircase"] == ["SUN"]
    assert lights["neon_room"] == [] and out["neon_room"]["reopened"]["world"] == [0.0, 0.0, 0.0]
    assert emitters["neon_room"] == ["orb_lamp", "strip_magenta", "strip_orange", "tube_cyan", "tv_screen"]
    area = [o for o in scene["product_shot"].values() if o["type"] == "LIGHT"]
    assert len(area) == 1 and area[0]["kind"] == "AREA" and area[0]["size"] == pytest.approx([1.2, 0.8])
    assert scene["product_shot"]["torus_knot"]["metallic"] == 1.0 and "suzanne" in scene["product_shot"]
    assert lights["bathroom"] == ["AREA"] and lights["furnished_room"] == []
    mirror = scene["bathroom"]["mirror"]
    assert mirror["metallic"] == 1.0 and mirror["roughness"] < 0.05
    assert scene["kitchen"]["pot"]["metallic"] == 1.0 and scene["kitchen"]["counter_top"]["roughness"] < 0.051
    assert sum(k.startswith("step") for k in scene["staircase"]) >= 10
    assert sum(o["type"] == "MESH" for o in scene["furnished_room"].values()) >= 60
    assert not any(emitters[n] for n in HELD_OUT if n != "neon_room")


def test_each_scene_is_lit_and_by_what_it_promises():
    """Tiny Cycles renders: every scene is lit; the neon room is black with every emission strength at 0, the
    kitchen black with its sun and its sky at 0 (its only light comes through the window)."""
    out = _json(run_py(_RENDER, timeout=300))
    for name in HELD_OUT:
        assert out[name]["lit"] > 0.02, (name, out[name])
    assert out["neon_room"]["off"] < 1e-5 and out["kitchen"]["off"] < 1e-5, out  # the denoiser's residue only
