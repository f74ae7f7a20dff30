"""The artist test set (scenes/artist.py): every scene builds, saves and reopens with
its render settings; the studio and the Cornell box hold what the set is for (metal, glass, film, an emissive
panel and no lamp objects); two builds are the same; the Cornell box is lit by its panel alone (a tiny Cycles
render); tiny_material_scene holds each material it promises."""
from __future__ import annotations

import json

import pytest

from ..conftest import ROOT, run_py

SCENES_ROOT = str(ROOT)
NAMES = ("living_room", "studio", "exterior", "cornell_emissive", "closed_room")

_DESCRIBE = """
import json, sys
sys.path.insert(0, SCENES_ROOT)
import bpy
from scenes import artist as A

def mat(o):
    m = o.active_material
    if m is None or m.node_tree is None:
        return None
    p = m.node_tree.nodes.get("Principled BSDF")
    g = lambda k: p.inputs[k].default_value
    return dict(name=m.name, base=[round(v, 4) for v in list(g("Base Color"))[:3]], metallic=g("Metallic"), roughness=g("Roughness"), transmission=g("Transmission Weight"),
                alpha=g("Alpha"), emission=list(g("Emission Color"))[:3], strength=g("Emission Strength"),
                specular=g("Specular IOR Level"),
                textured=bool(p.inputs["Base Color"].is_linked))

def describe(scene):
    objs = {}
    for o in sorted(scene.objects, key=lambda o: o.name):
        d = dict(type=o.type, matrix=[round(v, 6) for row in o.matrix_world for v in row])
        if o.type == "MESH":
            d.update(verts=len(o.data.vertices), mat=mat(o))
        elif o.type == "LIGHT":
            d.update(kind=o.data.type, energy=o.data.energy, size=getattr(o.data, "size", None))
        objs[o.name] = d
    r, ee = scene.render, scene.eevee
    return dict(objects=objs, camera=scene.camera.name if scene.camera else None, engine=r.engine,
                size=[r.resolution_x, r.resolution_y, r.resolution_percentage], raytracing=ee.use_raytracing,
                fast_gi=ee.use_fast_gi, samples=ee.taa_render_samples, view=scene.view_settings.view_transform,
                film_transparent=r.film_transparent, max_bounces=scene.cycles.max_bounces,
                frame=scene.frame_current, world=list(scene.world.color) if scene.world else None)

out = {}
for name in A.NAMES:
    first = describe(A.build(name, (64, 36)))
    second = describe(A.build(name, (64, 36)))
    path = sys.argv[1] + "/" + name + ".blend"
    A.save(bpy.context.scene, path)
    from ssgi.ssgi_addon.blender import blendfile
    reopened = describe(blendfile.open_blend(path))
    out[name] = dict(first=first, second=second, reopened=reopened)
tiny = A.tiny_material_scene(A.scenes.empty_scene())
out["tiny"] = dict(names=tiny, scene=describe(bpy.context.scene))
print("JSON" + json.dumps(out))
""".replace("SCENES_ROOT", repr(SCENES_ROOT))


@pytest.fixture(scope="module")
def described(tmp_path_factory):
    d = tmp_path_factory.mktemp("artist")
    p = run_py(_DESCRIBE, str(d), timeout=600)
    line = [ln for ln in p.stdout.splitlines() if ln.startswith("JSON")][-1]
    return json.loads(line[4:]), d


def test_each_scene_builds_saves_and_reopens_with_its_render_settings(described):
    out, d = described
    assert set(NAMES) <= set(out)
    for name in NAMES:
        assert (d / f"{name}.blend").stat().st_size > 10_000
        assert not list(d.glob(f".{name}*")), "a temporary file was left behind"
        s = out[name]["reopened"]
        assert s["objects"] == out[name]["first"]["objects"], name  # the file holds what was built
        assert s["camera"] and s["objects"][s["camera"]]["type"] == "CAMERA", name
        assert (s["engine"], s["raytracing"], s["fast_gi"], s["samples"]) == ("BLENDER_EEVEE", True, True, 16), name
        assert s["view"] == "Standard" and s["size"] == [64, 36, 100] and s["frame"] == 1, name
        assert s["max_bounces"] == 8, name
        assert sum(o["type"] == "MESH" for o in s["objects"].values()) >= 4, name


def test_two_builds_are_the_same(described):
    out, _ = described
    for name in NAMES:
        assert out[name]["first"] == out[name]["second"], name


def _mats(scene):
    return {n: o["mat"] for n, o in scene["objects"].items() if o["type"] == "MESH"}


def test_studio_holds_a_gold_metal_sphere_glass_and_film_under_big_area_lights(described):
    s = described[0]["studio"]["reopened"]
    m = _mats(s)
    assert m["gold_sphere"]["metallic"] == 1.0 and abs(m["gold_sphere"]["roughness"] - 0.2) < 1e-6
    assert m["glass_cylinder"]["transmission"] == 1.0 and m["glass_cylinder"]["roughness"] == 0.0
    assert m["film"]["alpha"] < 0.5
    lights = [o for o in s["objects"].values() if o["type"] == "LIGHT"]
    assert 1 <= len(lights) <= 2 and all(o["kind"] == "AREA" and o["size"] >= 1.0 for o in lights)
    assert s["film_transparent"] is True


def test_cornell_box_is_lit_only_by_an_emissive_panel_and_holds_a_mirror_ball(described):
    s = described[0]["cornell_emissive"]["reopened"]
    assert not [n for n, o in s["objects"].items() if o["type"] == "LIGHT"]
    assert s["world"] == [0.0, 0.0, 0.0]
    m = _mats(s)
    assert m["emissive_panel"]["strength"] > 1.0 and min(m["emissive_panel"]["emission"]) > 0.5
    assert [n for n, v in m.items() if v["strength"] > 0] == ["emissive_panel"]
    assert m["mirror_ball"]["metallic"] == 1.0 and m["mirror_ball"]["roughness"] <= 0.02
    assert m["diffuse_box"]["metallic"] == 0.0 and m["diffuse_box"]["roughness"] == 1.0
    red, green = m["left"]["base"], m["right"]["base"]
    assert red[0] > 3 * red[1] and green[1] > 3 * green[0]  # red left and green right walls
    assert all(m[k]["base"][0] == m[k]["base"][1] == m[k]["base"][2] for k in ("floor", "ceiling", "back"))


def test_living_room_and_control_hold_what_they_promise(described):
    out = described[0]
    lr = out["living_room"]["reopened"]
    m = _mats(lr)
    assert not [o for o in lr["objects"].values() if o["type"] == "LIGHT"]  # the shade and the window light it
    assert m["lamp_shade"]["strength"] > 0 and m["lamp_pole"]["metallic"] == 1.0
    assert m["floor"]["roughness"] < 0.15 and m["floor"]["specular"] == 0.5
    assert any(v["textured"] for v in m.values())
    ex = out["exterior"]["reopened"]
    assert [o["kind"] for o in ex["objects"].values() if o["type"] == "LIGHT"] == ["SUN"]
    cr = out["closed_room"]["reopened"]
    assert [o["kind"] for o in cr["objects"].values() if o["type"] == "LIGHT"] == ["POINT"]
    assert all(v["roughness"] == 1.0 and v["specular"] == 0.0 for v in _mats(cr).values())


def test_tiny_material_scene_holds_each_material(described):
    t = described[0]["tiny"]
    names, s = t["names"], t["scene"]
    assert set(names) == {"camera", "light", "floor", "emissive", "metal", "glass", "glossy"}
    assert all(n in s["objects"] for n in names.values()) and s["camera"] == names["camera"]
    assert [o["type"] for o in s["objects"].values()].count("LIGHT") == 1
    m = _mats(s)
    assert m[names["emissive"]]["strength"] > 1.0 and max(m[names["emissive"]]["emission"]) > 0.5
    assert m[names["metal"]]["metallic"] == 1.0
    assert m[names["glass"]]["transmission"] == 1.0
    assert abs(m[names["glossy"]]["roughness"] - 0.1) < 1e-6 and m[names["glossy"]]["metallic"] == 0.0
    assert m[names["floor"]]["roughness"] == 1.0


def test_the_cornell_box_is_lit_by_its_panel():
    """A tiny Cycles render is not black, and black with the panel's emission off: the panel is the light."""
    p = run_py("""
        import json, sys
        sys.path.insert(0, %r)
        import bpy
        from scenes import artist as A
        scene = A.build("cornell_emissive", (64, 36))
        lit, _ = A.render_cycles(scene, 4)
        bpy.data.materials["panel_emission"].node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 0.0
        off, _ = A.render_cycles(scene, 4)
        print("JSON" + json.dumps([float(lit.mean()), float(off.mean())]))
    """ % SCENES_ROOT, timeout=300)
    lit, off = json.loads([ln for ln in p.stdout.splitlines() if ln.startswith("JSON")][-1][4:])
    assert lit > 0.05 and off < 1e-4, (lit, off)
