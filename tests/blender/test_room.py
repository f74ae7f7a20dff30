"""The random room (ssgi_addon/blender/room.py, ``cli.py randomize``) on the real bpy module: determinism across
processes, counts, camera placement checked against the built meshes, diffuse materials, --save."""
from __future__ import annotations

import json
from collections import Counter

from ssgi.ssgi_addon.blender import room

from ..conftest import run_cli, run_py


def _jsonable(d):
    return json.loads(json.dumps(d))  # tuples -> lists, as they come back from a subprocess


def test_same_seed_same_scene_in_two_processes_and_other_seeds_differ(factory_bpy):
    code = """
    import json, bpy
    from ssgi.ssgi_addon.blender import room
    bpy.ops.wm.read_factory_settings(use_empty=True)
    out = {}
    for seed in (11, 12):
        room.build_room(seed, bpy.context.scene)
        out[seed] = room.describe_scene(bpy.context.scene)
    print("JSON" + json.dumps(out))
    """
    # another hash seed in the other process: nothing may depend on set/dict hashing order
    p = run_py(code, env={"PYTHONHASHSEED": "12345"})
    other = json.loads(p.stdout.split("JSON", 1)[1])
    scene = factory_bpy.context.scene
    room.build_room(11, scene)
    here = _jsonable(room.describe_scene(scene))
    assert here == other["11"]
    # names, transforms, colours and light settings are all in the description
    lights = [v for v in here.values() if v["type"] == "LIGHT"]
    assert lights and all({"energy", "colour", "radius", "matrix"} <= set(v) for v in lights)
    assert sum("colour" in v for v in here.values() if v["type"] == "MESH") >= 8  # >= 5 walls + 3 objects
    # rebuilding in place gives the same scene again (nothing of the previous room is left)
    room.build_room(12, scene)
    room.build_room(11, scene)
    assert _jsonable(room.describe_scene(scene)) == here
    # another seed: another room
    assert other["12"] != other["11"]
    objs = lambda d: {k: v["matrix"] for k, v in d.items() if ".obj." in k}  # noqa: E731
    assert objs(other["12"]) != objs(other["11"])


def test_counts_kinds_and_ranges_over_many_seeds():
    n_obj, n_light, shapes, kinds, opens = Counter(), Counter(), Counter(), Counter(), 0
    for seed in range(400):
        p = room.room_params(seed)
        W, D, H = p["size"]
        n_obj[len(p["objects"])] += 1
        n_light[len(p["lights"])] += 1
        shapes.update(o["shape"] for o in p["objects"])
        kinds.update(li["type"] for li in p["lights"])
        opens += p["open_side"] is not None
        for li in p["lights"]:  # lights inside the room
            x, y, z = li["location"]
            assert abs(x) < W / 2 and abs(y) < D / 2 and 0 < z < H, (seed, li)
            assert li["energy"] > 0 and 0 < li["radius"]
        for o in p["objects"]:
            assert all(0.1 < s < 1.0 for s in o["scale"]), (seed, o)
    assert set(n_obj) == set(range(3, 11)), n_obj  # 3..10 objects, each count occurs
    assert set(n_light) == {1, 2, 3}, n_light
    assert set(shapes) == set(room.SHAPES) and set(kinds) == set(room.LIGHT_TYPES)
    assert 0.15 * 400 < opens < 0.45 * 400  # some rooms have an open side (~30 %)
    assert room.room_params(5) == room.room_params(5)


def _frustum_hits(bpy, scene, n=5):
    """Distances (m) from the camera to the first surface along an n x n grid of rays over the frame."""
    dg = bpy.context.evaluated_depsgraph_get()
    cam = scene.camera
    rot = cam.matrix_world.to_3x3()
    origin = cam.matrix_world.translation
    tr, br, bl, tl = cam.data.view_frame(scene=scene)
    out = []
    for i in range(n):
        for j in range(n):
            u, v = i / (n - 1), j / (n - 1)
            d = (rot @ bl.lerp(br, u).lerp(tl.lerp(tr, u), v)).normalized()
            hit, loc, *_ = scene.ray_cast(dg, origin, d)
            out.append((loc - origin).length if hit else float("inf"))
    return out


def test_camera_is_outside_objects_and_away_from_walls_for_50_built_rooms(factory_bpy):
    bpy = factory_bpy
    scene = bpy.context.scene
    closest = []
    for seed in range(1000, 1050):  # the seeds of the big bake start at 1000
        prm = room.room_params(seed)
        room.build_room(seed, scene)
        bpy.context.view_layer.update()  # matrix_world
        W, D, H = prm["size"]
        cam = scene.camera
        c = cam.matrix_world.translation
        objs = [o for o in scene.objects if o.type == "MESH" and ".obj." in o.name]
        lights = [o for o in scene.objects if o.type == "LIGHT"]
        assert 3 <= len(objs) <= 10 and 1 <= len(lights) <= 3, seed
        # inside the room, at least 30 cm from every wall, floor and ceiling plane
        gaps = (c.x + W / 2, W / 2 - c.x, c.y + D / 2, D / 2 - c.y, c.z, H - c.z)
        assert min(gaps) > 0.3, (seed, gaps)
        # not inside any object's (oriented) bounding box, with a 5 cm margin
        for o in objs:
            lp = o.matrix_world.inverted() @ c
            lo = [min(v[k] for v in o.bound_box) for k in range(3)]
            hi = [max(v[k] for v in o.bound_box) for k in range(3)]
            margin = [0.05 / s for s in o.matrix_world.to_scale()]
            assert not all(lo[k] - margin[k] < lp[k] < hi[k] + margin[k] for k in range(3)), (seed, o.name)
        # it never faces a surface from a few centimetres: every ray over the frame travels > 25 cm
        hits = _frustum_hits(bpy, scene)
        closest.append(min(hits))
        assert min(hits) > 0.25, (seed, min(hits))
        # it looks toward the objects: the centre ray of the frame ends within the room, not at infinity
        centre = hits[len(hits) // 2]
        assert centre < max(W, D, H) * 2 or prm["open_side"], (seed, centre)
    assert min(closest) < 1.0  # the check does see nearby surfaces (some views have an object close by)


def test_all_materials_are_diffuse(factory_bpy):
    scene = factory_bpy.context.scene
    for seed in (0, 1, 2, 3):
        room.build_room(seed, scene)
        mats = {m for o in scene.objects if o.type == "MESH" for m in o.data.materials}
        assert len(mats) == len([o for o in scene.objects if o.type == "MESH"])
        for m in mats:
            out = next(n for n in m.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
            links = out.inputs["Surface"].links
            assert len(links) == 1
            p = links[0].from_node
            assert p.bl_idname == "ShaderNodeBsdfPrincipled", m.name
            v = {i.name: i.default_value for i in p.inputs if hasattr(i, "default_value")}
            assert not any(i.is_linked for i in p.inputs), m.name
            assert v["Roughness"] == 1.0 and v["Specular IOR Level"] == 0.0 and v["Metallic"] == 0.0
            for k in ("Transmission Weight", "Coat Weight", "Sheen Weight", "Subsurface Weight", "Emission Strength"):
                assert v[k] == 0.0, (m.name, k)
            assert v["Alpha"] == 1.0
            rgb = tuple(v["Base Color"])[:3]
            assert 0.0 <= min(rgb) and max(rgb) <= 0.9


def test_randomize_save_then_open(factory_bpy, tmp_path):
    bpy = factory_bpy
    f = tmp_path / "room.blend"
    p = run_cli("randomize", "--seed", "7", "--save", str(f), "--json")
    res = json.loads(p.stdout)
    assert res["ok"] and res["saved"] == str(f) and f.stat().st_size > 10_000
    bpy.ops.wm.open_mainfile(filepath=str(f), load_ui=False)
    opened = _jsonable(room.describe_scene(bpy.context.scene))
    assert bpy.context.scene.camera is not None and bpy.context.scene.camera.name == "ssgi.camera"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    room.build_room(7, bpy.context.scene)
    assert opened == _jsonable(room.describe_scene(bpy.context.scene))
    # a folder that does not exist: exit 2 naming it, nothing written
    bad = tmp_path / "no" / "room.blend"
    p = run_cli("randomize", "--seed", "7", "--save", str(bad), check=False)
    assert p.returncode == 2 and str(bad.parent) in p.stderr and "does not exist" in p.stderr
    assert not bad.parent.exists()


def test_clear_room_removes_everything_it_added(factory_bpy):
    bpy = factory_bpy
    scene = bpy.context.scene
    room.build_room(0, scene)
    assert any(o.get("ssgi_room") for o in scene.objects)
    room.clear_room(scene)
    assert not any(o.get("ssgi_room") for o in scene.objects)
    assert not [m for m in bpy.data.materials if m.get("ssgi_room")]
    assert not [m for m in bpy.data.meshes if m.get("ssgi_room")]
    assert scene.world is None and not [w for w in bpy.data.worlds if w.get("ssgi_room")]


def test_rebuilding_rooms_in_one_scene_keeps_one_world_with_one_name(factory_bpy):
    """A room replaced by another leaves one world, always named ssgi.world (it alternated with
    ssgi.world.001 before: the new world was made while the old one still existed)."""
    bpy = factory_bpy
    scene = bpy.context.scene
    for seed in (0, 1, 2, 3):
        room.build_room(seed, scene)
        assert scene.world.name == "ssgi.world"
        assert [w.name for w in bpy.data.worlds if w.get("ssgi_room")] == ["ssgi.world"]
