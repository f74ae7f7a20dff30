"""Fit to Scene on real Blender: cli.py fit on a tiny room, the jittered cameras, the SSGI node
rendering a fitted model, the Fit to Scene operator. The bpy-free half is tests/unit/test_fit.py."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ssgi.model.learn import checkpoint

from ..conftest import clean, run_cli, run_py
from ..unit.test_fit import ABLATE_ALL, generic, views  # noqa: F401  (generic, views: fixtures)


# ------------------------------------------------------------------------------------------ a real scene

@pytest.fixture(scope="module")
def scene_fit(tmp_path_factory, generic):
    """A tiny room (tests/test_node.py's: camera moving over frames 1-3), fitted by `cli.py fit` with a budget
    of seconds (the baker renders the views at 64x36, 4 Cycles samples), then rendered through the SSGI node
    with the fitted model."""
    import hashlib

    from .test_node import SCENE
    d = tmp_path_factory.mktemp("scene_fit")
    blend = d / "room.blend"
    run_py(SCENE + f'''
sc = build_room({str(d / "unused_####")!r})
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
''', timeout=120)
    sha = hashlib.sha256(blend.read_bytes()).hexdigest()
    model = d / "room_fit.pt"
    p = run_cli("fit", "--blend", str(blend), "--out", str(model), "--views", "6", "--minutes", "1.2", "--size", "64x36",
                "--ref-samples", "4", "--init", str(generic), "--drop-tol", str(ABLATE_ALL), "--min-run-seconds", "1",
                "--threads", "1", "--crop", "32", "--json", timeout=900)
    summary = json.loads(p.stdout)
    r = run_cli("render", "--blend", str(blend), "--setup", "--model", str(model), "--out", str(d / "ssgi_####"),
                "--frames", "2", "--save-passes", str(d / "passes"), "--json", timeout=300)
    return dict(dir=d, blend=blend, sha=sha, model=model, summary=summary, stderr=clean(p.stderr),
                render=json.loads(r.stdout))


def test_cli_fit_bakes_views_of_the_scene_and_holds_out_jittered_cameras(scene_fit):
    from ssgi.model.dataset import folder as data_folder
    s = scene_fit["summary"]
    assert s["ok"] and s["status"] == "done"
    work = scene_fit["dir"] / "room_fit.fit"
    plan = json.loads((work / "views_plan.json").read_text())
    assert plan["frames"] == [1, 3]  # the animation's ends: frames spread over frame_start..frame_end
    cams = plan["cameras"]
    assert cams["Camera"] == "train"
    jit = {c: r for c, r in cams.items() if c != "Camera"}
    assert len(jit) == 3 and sorted(jit.values()) == ["test", "train", "val"]
    (views,) = [p for p in work.glob("views-*") if p.is_dir()]
    m = data_folder.open_folder(views, scenes=True)
    assert s["views"] == str(views)
    got = sorted((v["camera"], v["frame"]) for v in m["samples"].values())
    assert got == sorted((c, f) for c in cams for f in (1, 3))  # every camera at every frame: 8 views
    rep = checkpoint.load(scene_fit["model"])["fit"]
    role = {k: cams[v["camera"]] for k, v in m["samples"].items()}
    assert sorted(rep["views"]["val"]) == sorted(k for k, r in role.items() if r == "val")
    assert sorted(rep["views"]["test"]) == sorted(k for k, r in role.items() if r == "test")
    assert rep["total_minutes" if "total_minutes" in rep else "minutes"] is not None
    import hashlib
    assert hashlib.sha256(scene_fit["blend"].read_bytes()).hexdigest() == scene_fit["sha"]  # the artist's file


def test_jittered_cameras_stay_near_the_scene_cameras(scene_fit):
    """In views.blend: each jittered camera lies within the plan's radius of its scene camera's pose at some
    frame, shares its lens, and looks within JITTER_DEG * sqrt(2) of the same direction."""
    work = scene_fit["dir"] / "room_fit.fit"
    out = scene_fit["dir"] / "cams.json"
    run_py(f'''
import bpy, json, math
bpy.ops.wm.open_mainfile(filepath={str(next(work.glob("views-*.blend")))!r})
sc = bpy.context.scene
cam = sc.objects["Camera"]
poses = []
for f in range(sc.frame_start, sc.frame_end + 1):
    sc.frame_set(f)
    m = cam.matrix_world.copy()
    poses.append((list(m.to_translation()), list(m.to_3x3().col[2])))
res = {{}}
for o in sc.objects:
    if o.name.startswith("ssgi.fit.view_"):
        m = o.matrix_world
        res[o.name] = dict(loc=list(m.to_translation()), z=list(m.to_3x3().col[2]), data=o.data.name,
                           role=o["ssgi_fit_role"])
json.dump(dict(poses=poses, views=res, lens=cam.data.name), open({str(out)!r}, "w"))
''', timeout=120)
    from ssgi.ssgi_addon.blender import views as sfit
    info = json.loads(out.read_text())
    plan = json.loads((work / "views_plan.json").read_text())
    assert len(info["views"]) == 3
    for name, v in info["views"].items():
        assert v["data"] == info["lens"] and v["role"] == plan["cameras"][name]
        dist = min(math.dist(v["loc"], p[0]) for p in info["poses"])
        assert 0 < dist <= plan["radius"] + 1e-6
        ang = min(math.degrees(math.acos(max(-1, min(1, sum(a * b for a, b in zip(v["z"], p[1])))))) for p in info["poses"])
        assert ang <= sfit.JITTER_DEG * math.sqrt(2) + 1e-3


def test_jittered_cameras_follow_their_animated_scene_camera(tmp_path):
    """A scene whose only animation is the camera (a dolly past a wall): every jittered camera is parented to
    its scene camera, so at each frame of the plan its world matrix is the base camera's @ its local offset,
    a different view at each frame; the offset passes no surface at any of the plan's frames."""
    out = tmp_path / "follow.json"
    run_py(f'''
import bpy, json, math
from ssgi.ssgi_addon.blender import views as sfit
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, 0))
bpy.ops.mesh.primitive_cube_add(size=2, location=(0, 6, 1))
bpy.ops.mesh.primitive_plane_add(size=20, location=(0.05, 0, 1), rotation=(0, math.pi / 2, 0))  # a wall near the path
bpy.ops.object.camera_add(location=(-1, -6, 1.5), rotation=(math.radians(80), 0, 0))
cam = bpy.context.object
sc.camera = cam
for f, x, rz in ((1, -1.0, 0.0), (9, -0.2, 0.6)):
    cam.location.x = x
    cam.rotation_euler.z = rz
    cam.keyframe_insert("location", frame=f)
    cam.keyframe_insert("rotation_euler", frame=f)
sc.frame_start, sc.frame_end = 1, 9
sc.frame_set(1)
plan = sfit.make_views(sc, views=24, seed=4)
res = dict(plan=plan, views={{}})
for o in sc.objects:
    if not o.name.startswith(sfit.VIEW_PREFIX):
        continue
    v = res["views"][o.name] = dict(parent=o.parent.name if o.parent else None, frames={{}})
    for f in plan["frames"]:
        sc.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        w, b = o.matrix_world.copy(), sc.objects[o["ssgi_fit_from"]].matrix_world.copy()
        a, c = b.to_translation(), w.to_translation()
        hit = (c - a).length > 0 and sc.ray_cast(dg, a, (c - a).normalized(), distance=(c - a).length)[0]
        v["frames"][f] = dict(world=[list(r) for r in w], base=[list(r) for r in b],
                              local=[list(r) for r in o.matrix_basis], hit=bool(hit))
json.dump(res, open({str(out)!r}, "w"))
''', timeout=120)
    r = json.loads(out.read_text())
    plan = r["plan"]
    assert len(plan["frames"]) >= 2 and len(r["views"]) >= 3
    for name, v in r["views"].items():
        fr = [v["frames"][str(f)] for f in plan["frames"]]
        worlds = [np.array(d["world"]) for d in fr]
        assert all(not np.allclose(worlds[0], w, atol=1e-4) for w in worlds[1:]), name  # a new view each frame
        assert v["parent"] == "Camera", name
        for d in fr:
            np.testing.assert_allclose(np.array(d["world"]), np.array(d["base"]) @ np.array(d["local"]), atol=1e-5)
            assert not d["hit"], name  # the move passes no surface at any frame the baker renders
            assert np.linalg.norm(np.array(d["local"])[:3, 3]) <= plan["radius"] + 1e-6


def test_fitted_model_lists_only_the_kept_passes_and_the_node_renders_with_it(scene_fit):
    from ssgi.model.dataset import exrio

    from .test_node import expected_image, read_rgba
    ck = checkpoint.load(scene_fit["model"])
    assert tuple(ck["inputs"]) == ("albedo", "direct") and scene_fit["summary"]["inputs"] == ["albedo", "direct"]
    assert scene_fit["render"]["inputs"] == "albedo,direct"
    # the node rendered what the model needs (+ depth and normals, which the render path always takes for the
    # world pixels and the depth normalisation, and EEVEE's own rest, which a diffuse-part model's image adds: the
    # fit's views hold the diffuse part), and nothing else (no AO; no EEVEE direct-lit colour
    # `eevee`, which only a whole-image model's composition reads)
    assert ck["arch"]["target"] == "ref_diffuse"
    passes = scene_fit["dir"] / "passes" / "000002.exr"
    planes, _ = exrio.read_exr(passes)
    assert {c.split(".")[0] for c in planes} == {"albedo", "direct", "depth", "normal", "rest"}
    g = exrio.read_sample(passes, groups=("albedo", "direct", "depth", "normal", "rest"))
    want, world = expected_image(scene_fit["model"], g, 100.0)
    got = read_rgba(scene_fit["dir"] / "ssgi_0002.exr")
    np.testing.assert_allclose(got[..., :3], want, rtol=1e-5, atol=1e-6)
    assert (~world).sum() > 100 and float(got[..., :3][~world].mean()) > 0


def test_cli_fit_errors_name_the_fault(tmp_path):
    p = run_cli("fit", "--blend", str(tmp_path / "nope.blend"), "--out", str(tmp_path / "m.pt"), check=False, timeout=120)
    assert p.returncode == 2 and "nope.blend: no such .blend file" in p.stderr and "Traceback" not in p.stderr
    p = run_cli("fit", "--blend", str(tmp_path / "x.blend"), "--out", str(tmp_path / "m.txt"), check=False, timeout=120)
    assert p.returncode == 2 and "must end in .pt" in p.stderr
    p = run_cli("fit", "--out", str(tmp_path / "m.pt"), check=False, timeout=120)
    assert p.returncode == 2 and "--blend FILE" in p.stderr
    assert not list(tmp_path.iterdir())


def test_fit_operator_runs_in_the_background_with_progress_and_cancel(scene_fit, tmp_path):
    """The Fit to Scene operator in Blender (bpy module): Cancel ends the child process group and writes
    nothing; a second run completes, reports its phases in order and sets the scene's model."""
    out = tmp_path / "op.pt"
    res = tmp_path / "res.json"
    run_py(f'''
import bpy, json, os, time, ssgi
from ssgi.ssgi_addon.runtime import jobs
ssgi.register()
bpy.ops.wm.open_mainfile(filepath={str(scene_fit["blend"])!r})
sc = bpy.context.scene
sc.ssgi.fit_out = {str(out)!r}
sc.ssgi.fit_views = 4
sc.ssgi.fit_minutes = 0.9
r = {{}}
assert bpy.ops.ssgi.fit_scene() == {{"FINISHED"}}
job = jobs.get("fit")
r["poll_while_running"] = bpy.ops.ssgi.fit_scene.poll()
t = time.time()
while job.pump() and job.state.get("phase") is None and time.time() - t < 120:
    time.sleep(0.05)
r["phase_at_cancel"] = job.state.get("phase")
from tests import ui_recorder
from ssgi.panels.fit_panel import SSGI_PT_fit
r["running_ops"] = [o[0] for o in ui_recorder.draw(SSGI_PT_fit).operators()]
bpy.ops.ssgi.cancel_job(job="fit")
job.wait(60)
r["cancel_status"] = job.state["status"]
from ssgi.ssgi_addon.runtime.launcher import group_members
r["group_alive"] = group_members(job.proc.pid)
r["model_after_cancel"] = os.path.exists({str(out)!r})
assert bpy.ops.ssgi.fit_scene() == {{"FINISHED"}}
job = jobs.get("fit")
prog = []
t = time.time()
while job.pump() and time.time() - t < 800:
    prog.append(float(job.state.get("progress", 0)))
    time.sleep(0.05)
phases = job.state.get("phases")
rec = ui_recorder.draw(SSGI_PT_fit)
r["done_labels"], r["done_ops"] = rec.labels(), [o[0] for o in rec.operators()]
r.update(status=job.state["status"], error=job.error, phases=phases, model_path=sc.ssgi.model_path,
         inputs=(job.result or {{}}).get("inputs"), max_progress=max(prog))
json.dump(r, open({str(res)!r}, "w"))
''', timeout=1200)
    r = json.loads(res.read_text())
    assert r["poll_while_running"] is False
    assert r["phase_at_cancel"] is not None and r["cancel_status"] == "cancelled"
    assert r["group_alive"] == [] and r["model_after_cancel"] is False
    assert r["status"] == "done", r["error"]
    assert r["model_path"] == str(out) and out.is_file()
    ph = r["phases"]
    assert ph[:3] == ["views", "bake", "size"] and ph[-1] == "done", ph
    assert r["inputs"] == list(checkpoint.load(out)["inputs"])
    # the panel: Cancel while it runs; afterwards the button, the kept inputs and the verdict
    assert r["running_ops"] == ["ssgi.cancel_job"]
    assert r["done_ops"] == ["ssgi.fit_scene"]
    assert f"Inputs: {', '.join(r['inputs'])}" in r["done_labels"]
    verdict = checkpoint.load(out)["fit"]["verdict"]
    assert any(l and l in verdict for l in r["done_labels"][1:]), r["done_labels"]


def test_fit_stage_runs_from_python_with_a_config(views, generic, tmp_path):
    """The fit stage without argparse: a FitSceneConfig on views baked before (roles derived from their
    cameras) -> pipeline.fit.run -> the summary; the held-out views are those of the derived plan's cameras."""
    from ssgi.model.evaluate import fit_report
    from ssgi.ssgi_addon.blender import views as fviews
    from ssgi.ssgi_addon.pipeline import fit as sfit
    out = tmp_path / "stage.pt"
    events = []
    cfg = sfit.FitSceneConfig(out=str(out), data=str(views), minutes=0.25, init=str(generic), threads=1, crop=32,
                              min_run_s=1.0, drop_tol=ABLATE_ALL, seed=1, command="test_fit_stage")
    res = sfit.run(cfg, progress=events.append, log=lambda m: None)
    assert res["status"] == "done" and out.is_file() and res["views"] == str(views) and res["bake_minutes"] == 0
    assert res["init"] == str(generic) and events and events[-1]["phase"] == "done"
    plan = fviews.derive_plan(views, seed=1)
    cam = {k: str(v["camera"]) for k, v in json.loads((views / "manifest.json").read_text())["samples"].items()}
    fit_info = checkpoint.load(out)["fit"]
    for role in ("val", "test"):
        assert sorted(fit_info["views"][role]) == sorted(k for k, c in cam.items() if plan["cameras"][c] == role)
    rep = json.loads(fit_report.report_paths(out)[0].read_text())
    assert rep["total_minutes"] == pytest.approx(res["total_minutes"]) and rep["bake_minutes"] == 0
