"""Artist-mode random scenes (ssgi_addon/blender/room_artist.py, room_artist_build.py) on the real bpy module:
the diffuse mode unchanged (frozen hashes), determinism, every feature at its probability over 200 seeds
(params only), emission-only rooms, camera placement, windows and sun direction in the built scene,
clear_room, ``cli.py randomize --mode artist`` and one tiny EEVEE render."""
from __future__ import annotations

import hashlib
import json
import math
from collections import Counter

import pytest

from ssgi.ssgi_addon.blender import room, room_artist as ra
from ssgi.ssgi_addon.blender import room_artist_build as rb

from ..conftest import run_cli, run_py

N = 200
PARAMS = {s: room.room_params(s, "artist") for s in range(N)}


def _sha(d) -> str:
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()


# room_params(seed) of the diffuse mode before artist mode existed (commit a9d591d): a shipped model and the
# bake's fixtures depend on these rooms
FROZEN_PARAMS = {
    0: "6f9fd4a978733ced1528ae5ca96a2cfdbf232b2e63d467a30b8916ef1ac9651a",
    7: "3f980e8aa520c3eb1ca83b734c37721d61a358d94dda8b86648c4c9fdc4d4c44",
    1000: "3b6223c717aa6b39f4d221a7d9f56425c553192fcc5f20ba6eaf4bb5ca1f6adf",
    99999: "74fb8b07e2223cdc08f456f1beaeea7d617613d3c7c7aeb4623ac1966542fe7f",
}
FROZEN_SCENES = {  # describe_scene of the built diffuse rooms, same commit, bpy 5.0.1
    0: "8f778bb8a71e5f21fdc4e86083fc387bd07c23afdf8254c9ee65dad97a43edd4",
    1000: "36c128781b634365c45d9ba3f3171e66bec71473b3a74e699869823990654ba0",
}


def test_diffuse_mode_is_unchanged(factory_bpy):
    for seed, h in FROZEN_PARAMS.items():
        assert _sha(room.room_params(seed)) == h, seed
        assert room.room_params(seed, mode="diffuse") == room.room_params(seed)
    scene = factory_bpy.context.scene
    for seed, h in FROZEN_SCENES.items():
        room.build_room(seed, scene, mode="artist")  # an artist scene before leaves nothing behind
        room.build_room(seed, scene)
        assert _sha(room.describe_scene(scene)) == h, seed
        assert "ssgi_room_mode" not in scene
    with pytest.raises(ValueError, match="artist"):
        room.room_params(1, mode="fancy")


def test_artist_params_are_deterministic_and_differ_from_diffuse():
    code = """
    import json
    from ssgi.ssgi_addon.blender import room
    print("JSON" + json.dumps({s: room.room_params(s, "artist") for s in (3, 4, 5)}))
    """
    other = json.loads(run_py(code, env={"PYTHONHASHSEED": "999"}).stdout.split("JSON", 1)[1])
    for s in (3, 4, 5):
        assert json.loads(json.dumps(PARAMS[s])) == other[str(s)]
    assert PARAMS[3] != PARAMS[4]
    assert room.room_params(3, "artist")["size"] != room.room_params(3)["size"]


def _materials(p):
    ms = [o["material"] for o in p["objects"] + p["emitters"]]
    ms += [w["material"] for w in p["walls"].values()] + ([p["ground"]] if "ground" in p else [])
    return ms


def _share(count, p, tol=0.08):
    return abs(count / N - p) < tol


def test_every_feature_at_its_probability_over_200_seeds():
    kinds = Counter(p["kind"] for p in PARAMS.values())
    assert all(_share(kinds[k], pk) for k, pk in ra.P_KIND), kinds
    rooms = [p for p in PARAMS.values() if p["kind"] != "exterior"]
    light = Counter(p["lighting"] for p in rooms)
    assert all(abs(light[k] / len(rooms) - pk) < 0.1 for k, pk in ra.P_LIGHTING), light
    ext = [p for p in PARAMS.values() if p["kind"] == "exterior"]
    assert abs(sum(p["sun"] is not None for p in ext) / len(ext) - ra.P_SUN_EXTERIOR) < 0.15
    opened = [p for p in rooms if p["kind"] == "open"]
    assert all(p["missing"] or any(w["window"] for w in p["walls"].values()) for p in opened)
    assert any(len(p["missing"]) == 2 for p in opened) and any(p["sun"] for p in opened)
    assert all(p["world"]["type"] == "black" and not p["missing"] and p["sun"] is None
               for p in rooms if p["kind"] == "closed")
    worlds = Counter(p["world"].get("sky", p["world"]["type"]) for p in PARAMS.values() if p["kind"] != "closed")
    assert set(worlds) == set(ra.SKIES) | {"gradient"}, worlds
    mats = [m for p in PARAMS.values() for m in _materials(p)]
    kinds = Counter(m["kind"] for m in mats)
    assert set(kinds) == {"dielectric", "metal", "glass", "emissive"}
    glass = [m for m in mats if m["kind"] == "glass"]
    assert all(m["transmission"] == 1.0 for m in glass)
    assert 0.4 < sum(m["roughness"] == 0.0 for m in glass) / len(glass) < 0.8  # clear and rough glass
    assert all(m["metallic"] == 1.0 for m in mats if m["kind"] == "metal")
    spec = [m["specular"] for m in mats if m["kind"] == "dielectric"]
    assert min(spec) < 0.1 and max(spec) > 0.9 and 0.3 < spec.count(0.5) / len(spec) < 0.7
    tex = Counter(m["texture"]["type"] for m in mats if m["texture"])
    assert set(tex) == set(ra.TEXTURES), tex
    floors = [p["walls"]["floor"]["material"] for p in rooms]
    assert abs(sum(m["texture"] is not None for m in floors) / len(floors) - ra.P_TEX_FLOOR) < 0.12
    assert 0.3 < sum(m["roughness"] < 0.31 for m in floors) / len(floors) < 0.65  # glossy floors
    emit = Counter(e["kind"] for p in rooms for e in p["emitters"])
    assert set(emit) == {"panel", "screen", "shade", "neon"}, emit
    big = [li for p in rooms for li in p["lights"] if li["type"] == "AREA" and li["size"] >= 1.0]
    assert len(big) > 0.15 * sum(p["lighting"] != "emission" for p in rooms)
    assert all(li["size"] <= 3.0 for p in rooms for li in p["lights"] if li["type"] == "AREA")


def test_emission_only_rooms_have_no_lamp_but_bright_emitters():
    only = [p for p in PARAMS.values() if p["lighting"] == "emission"]
    assert len(only) > 0.15 * N
    for p in only:
        assert p["lights"] == [] and p["sun"] is None, p["seed"]
        strengths = [e["material"]["strength"] for e in p["emitters"]]
        assert strengths and min(strengths) > 0.5, (p["seed"], strengths)
    lamps = [p for p in PARAMS.values() if p["lighting"] == "lamps"]
    assert lamps and all(p["lights"] and not p["emitters"] for p in lamps)


def test_camera_inside_the_scene_and_outside_every_object():
    for s, p in PARAMS.items():
        c = p["camera"]["location"]
        for o in p["objects"] + p["emitters"]:
            if ".bldg." in o["name"]:  # buildings: the footprint stays outside the plaza the camera is in
                assert math.hypot(*o["location"][:2]) - math.hypot(*o["scale"][:2]) >= ra.PLAZA - 1e-6
                continue
            assert math.dist(c, o["location"]) > o["radius"], (s, o["name"])
        if p["kind"] == "exterior":
            assert 1.5 <= c[2] <= 1.8 and math.hypot(c[0], c[1]) <= 7.0, s  # human height, in the plaza
        else:
            W, D, H = p["size"]
            assert abs(c[0]) < W / 2 - 0.5 and abs(c[1]) < D / 2 - 0.5 and 0.4 < c[2] < H - 0.5, s


def _seed(pred):
    return next(s for s, p in PARAMS.items() if pred(p))


def _ssgi_datablocks(bpy):
    cols = (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras,
            bpy.data.worlds, bpy.data.images)
    return [d.name for c in cols for d in c if d.get("ssgi_room") or d.name.startswith(room.PREFIX)]


def test_built_scenes_materials_windows_sun_and_clear_room(factory_bpy):
    bpy = factory_bpy
    from mathutils import Vector
    scene = bpy.context.scene
    seeds = {_seed(lambda p: p["lighting"] == "emission"), _seed(lambda p: p["kind"] == "exterior" and p["sun"]),
             _seed(lambda p: any(e["kind"] == "screen" for e in p["emitters"])),
             *(_seed(lambda p, side=side: p["walls"].get(side, {}).get("window")) for side in ra.SIDES),
             _seed(lambda p: any(m["texture"] and m["texture"]["type"] == "image" for m in _materials(p)))}
    for s in sorted(seeds):
        p = PARAMS[s]
        room.build_room(s, scene, mode="artist")
        bpy.context.view_layer.update()
        assert scene["ssgi_room_mode"] == "artist" and scene.camera.name == "ssgi.camera"
        desc = room.describe_scene(scene)
        types = Counter(v["type"] for v in desc.values())
        assert types["LIGHT"] == len(p["lights"]) + (p["sun"] is not None), s
        assert types["MESH"] == len(p["walls"]) + len(p["objects"]) + len(p["emitters"]) + ("ground" in p)
        for k, o in desc.items():  # every mesh: a Principled BSDF as in the params
            if o["type"] == "MESH":
                assert "Metallic" in o["material"], k
        if p["lighting"] == "emission":
            assert types["LIGHT"] == 0
            assert max(o["material"]["Emission Strength"] for o in desc.values() if o["type"] == "MESH") > 0.5
        if p["sun"] is not None:  # the sun light shines from the sky's sun
            sun = scene.objects["ssgi.light.sun"]
            toward = sun.matrix_world.to_3x3() @ Vector((0, 0, 1))
            assert (toward - Vector(rb._sun_dir(p["sun"]["elevation"], p["sun"]["azimuth"]))).length < 1e-5
            assert toward.z > 0.2
        inward = {"wall_xn": (1, 0, 0), "wall_xp": (-1, 0, 0), "wall_yn": (0, 1, 0), "wall_yp": (0, -1, 0)}
        for e in p["emitters"]:
            if e["kind"] in ("screen", "neon"):  # a screen faces into the room; a neon tube runs along its wall
                o = scene.objects[e["name"]]
                axis = o.matrix_world.to_3x3().normalized() @ Vector((0, 0, 1))
                n = Vector(inward[e["side"]])
                assert (axis - n).length < 1e-5 if e["kind"] == "screen" else abs(axis.dot(n)) < 1e-5, e
                assert abs(axis.z) < 1e-5
        dg = bpy.context.evaluated_depsgraph_get()
        for w, d in p["walls"].items():
            if d["window"] is None:
                continue
            # a ray out through the window's centre, from 10 cm inside, leaves the room; one below it does not
            W, D, H = p["size"]
            u0, u1, v0, v1 = d["window"]
            u = (u0 + u1) / 2
            at, out = {"wall_xn": ((-W / 2, u * D / 2), (-1, 0)), "wall_xp": ((W / 2, u * D / 2), (1, 0)),
                       "wall_yn": ((u * W / 2, -D / 2), (0, -1)), "wall_yp": ((u * W / 2, D / 2), (0, 1))}[w]
            n = Vector((*out, 0.0))
            for v, solid in (((v0 + v1) / 2, False), (-0.97, True)):
                origin = Vector((*at, H / 2 + v * H / 2)) - 0.1 * n
                hit, *_ = scene.ray_cast(dg, origin, n, distance=0.2)
                assert hit == solid, (s, w, v)
            wall = scene.objects[f"ssgi.room.{w}"]
            assert len(wall.data.polygons) == 4
            area = sum(f.area for f in wall.data.polygons) * wall.scale.x * wall.scale.y
            u0, u1, v0, v1 = d["window"]
            assert area == pytest.approx(4 * wall.scale.x * wall.scale.y * (1 - (u1 - u0) * (v1 - v0) / 4), rel=1e-4)
        if any(m["texture"] and m["texture"]["type"] == "image" for m in _materials(p)):
            ims = [i for i in bpy.data.images if i.get("ssgi_room")]
            assert ims and all(i.packed_file is not None and i.size[0] == 128 for i in ims)
    assert _ssgi_datablocks(bpy)
    room.clear_room(scene)
    assert _ssgi_datablocks(bpy) == [] and scene.world is None


def test_built_artist_cameras_are_outside_every_mesh(factory_bpy):
    """As the diffuse rooms' test: the camera is not inside any mesh's oriented bounding box (5 cm margin)."""
    bpy = factory_bpy
    scene = bpy.context.scene
    for s in range(0, 40):
        room.build_room(s, scene, mode="artist")
        bpy.context.view_layer.update()
        c = scene.camera.matrix_world.translation
        for o in scene.objects:
            if o.type != "MESH" or ".room." in o.name or o.name == "ssgi.ground":
                continue
            lp = o.matrix_world.inverted() @ c
            lo = [min(v[k] for v in o.bound_box) for k in range(3)]
            hi = [max(v[k] for v in o.bound_box) for k in range(3)]
            margin = [0.05 / max(sc, 1e-3) for sc in o.matrix_world.to_scale()]
            assert not all(lo[k] - margin[k] < lp[k] < hi[k] + margin[k] for k in range(3)), (s, o.name)


def test_randomize_cli_artist_mode(tmp_path):
    p = run_cli("randomize", "--seed", "3", "--mode", "artist", "--json")
    res = json.loads(p.stdout)
    assert res["ok"] and res["mode"] == "artist" and res["objects"] > 5
    p = run_cli("randomize", "--seed", "3", "--mode", "shiny", check=False)
    assert p.returncode == 2 and "artist" in p.stderr


def test_tiny_eevee_render_of_an_emission_only_room(tmp_path):
    """EEVEE renders an artist room lit only by emitters (no lamp). EEVEE (no ray tracing, no fast GI) lets
    emission light nothing: the room is black but for the emitters, which show in their own bright colour."""
    seed = _seed(lambda p: p["lighting"] == "emission" and p["kind"] == "closed")
    out = tmp_path / "room.png"
    code = f"""
    import bpy
    from ssgi.ssgi_addon.blender import room
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = room.build_room({seed}, bpy.context.scene, mode="artist")
    sc.render.engine = "BLENDER_EEVEE"
    sc.eevee.taa_render_samples = 1
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 36, 100
    sc.render.image_settings.file_format = "PNG"
    sc.render.filepath = {str(out)!r}
    bpy.ops.render.render(write_still=True)
    """
    run_py(code, timeout=300)
    import numpy as np
    from PIL import Image
    img = np.asarray(Image.open(out).convert("RGB"), np.float32) / 255
    assert img.shape == (36, 64, 3)
    bright = img.max(axis=-1) > 0.9
    assert 0.005 < bright.mean() < 0.5  # the emitter is in view, saturated
    assert np.median(img) < 0.05  # the rest: unlit in EEVEE (what the network must add)


def test_randomize_room_operator_and_panel_take_the_mode():
    code = """
    import json, bpy
    import ssgi
    from ssgi.panels import bake_panel
    from tests import ui_recorder
    bpy.ops.wm.read_factory_settings(use_empty=True)
    ssgi.register()
    rec = ui_recorder.draw(bake_panel.SSGI_PT_bake)  # checks that the operator has the properties set
    assert bpy.ops.ssgi.randomize_room(seed=4, mode="artist") == {"FINISHED"}
    rs = bpy.data.scenes["SSGI Room 4"]
    out = [rs.get("ssgi_room_mode"), rs.ssgi.room_mode, "room_mode" in rec.props()]
    with bpy.context.temp_override(scene=rs):
        assert bpy.ops.ssgi.randomize_room(seed=4, mode="diffuse") == {"FINISHED"}
    out += [rs.get("ssgi_room_mode"), rs.ssgi.room_mode]
    print("JSON" + json.dumps(out))
    """
    out = json.loads(run_py(code).stdout.split("JSON", 1)[1])
    assert out == ["artist", "artist", True, None, "diffuse"]


def test_randomize_save_artist_keeps_generated_images(factory_bpy, tmp_path):
    bpy = factory_bpy
    seed = _seed(lambda p: any(m["texture"] and m["texture"]["type"] == "image" for m in _materials(p)))
    f = tmp_path / "artist.blend"
    run_cli("randomize", "--seed", str(seed), "--mode", "artist", "--save", str(f), "--json")
    bpy.ops.wm.open_mainfile(filepath=str(f), load_ui=False)
    opened = json.loads(json.dumps(room.describe_scene(bpy.context.scene)))
    ims = [i for i in bpy.data.images if i.get("ssgi_room")]
    assert ims and all(i.packed_file is not None for i in ims)
    import numpy as np
    px = np.asarray(ims[0].pixels[:]).reshape(-1, 4)[:, :3]
    assert px.std() > 0.02 and px.max() > 0.05  # the tiles came back from the file, not a blank image
    bpy.ops.wm.read_factory_settings(use_empty=True)
    room.build_room(seed, bpy.context.scene, mode="artist")
    assert opened == json.loads(json.dumps(room.describe_scene(bpy.context.scene)))
