"""Fit a shot on real Blender: the plan withholds whole frames, the bake keeps away from
them, a tiny fit scores exactly those frames as the node renders them, and bad frame ranges are one-line
errors. The shot is scenes/shots.py's "ripple" (a moving camera, a moving cube, a Wave and a Simple
Deform modifier) at 64x36 over 20 frames, EEVEE at 1 sample. The module's fit is the one a user runs: its model
learns Cycles' diffuse part, and the shot's Principled materials are rough, so its views hold no EEVEE rest and it
fits no reflection map (tests/blender/test_reflmap.py fits a glossy shot)."""
from __future__ import annotations

import json

import pytest

from ssgi.model.learn import checkpoint
from ssgi.model.errors import UserError
from ssgi.ssgi_addon.blender import views as fviews

from ..conftest import run_cli, run_py, save_shot
from ..unit.test_fit import ABLATE_ALL, generic  # noqa: F401  (generic: a fixture)

SHOT = (1, 20)
# the module's fit bakes 6 views and renders 5 withheld frames (each: the node's passes, two Cycles renders); the
# suite's 900 s guard is too short for that on a shared machine (it ran out at load average 14-17)
pytestmark = pytest.mark.timeout(2400)


def _far(frames, withheld, gap=fviews.GAP):
    return all(abs(f - w) > gap for f in frames for w in withheld)


def test_withheld_frames_are_spread_over_the_shot_with_room_between():
    for a, b in ((1, 20), (1, 48), (10, 130), (1, 21)):
        w = fviews.withheld_frames(a, b)
        assert len(w) >= fviews.N_WITHHELD == 5
        assert a < w[0] and w[-1] < b  # none at the ends
        n = b - a + 1
        assert w[0] - a < n / 5 and b - w[-1] < n / 5  # spread: one in each fifth of the shot
        assert all(y - x >= 3 for x, y in zip(w, w[1:]))
        ok = fviews.eligible_frames(a, b, w)
        assert _far(ok, w) and len(ok) >= 5
        assert set(ok) | {f for x in w for f in (x - 1, x, x + 1)} == set(range(a, b + 1))
        sp = fviews.spread(ok, 4)
        assert sp[0] == ok[0] and sp[-1] == ok[-1] and len(sp) == 4


def test_bad_shots_are_refused_by_the_plan():
    with pytest.raises(UserError, match=r"--frames 20-1: the shot ends before it starts"):
        fviews.check_shot(20, 1)
    with pytest.raises(UserError, match=r"--frames 1-12: 12 frame\(s\) are too few to withhold 5 frames"):
        fviews.check_shot(1, 12)


@pytest.fixture(scope="module")
def shot_fit(tmp_path_factory, generic):
    d = tmp_path_factory.mktemp("shot_fit")
    blend = d / "ripple.blend"
    save_shot("ripple", blend, (64, 36), SHOT[1], timeout=120)
    model = d / "shot.pt"
    p = run_cli("fit", "--blend", str(blend), "--out", str(model), "--frames", f"{SHOT[0]}-{SHOT[1]}", "--views", "6",
                "--minutes", "0.5", "--size", "64x36", "--ref-samples", "2", "--init", str(generic), "--drop-tol",
                str(ABLATE_ALL), "--min-run-seconds", "1", "--threads", "1", "--crop", "32", "--json",
                timeout=2400)
    return dict(dir=d, blend=blend, model=model, summary=json.loads(p.stdout))


def test_fit_shot_bakes_no_view_within_a_frame_of_the_withheld_frames(shot_fit):
    from ssgi.model.dataset import folder as data_folder
    work = shot_fit["dir"] / "shot.fit"
    plan = json.loads((work / "views_plan.json").read_text())
    assert plan["shot"] == list(SHOT) and plan["test_frames"] == fviews.withheld_frames(*SHOT) == [3, 7, 11, 14, 18]
    assert plan["test_camera"] == "camera" and _far(plan["frames"], plan["test_frames"])
    assert sorted(set(plan["cameras"].values())) == ["train", "val"]  # the test is the withheld frames
    (views,) = [p for p in work.glob("views-*") if p.is_dir()]
    m = data_folder.open_folder(views, scenes=True)
    baked = [(v["camera"], int(v["frame"])) for v in m["samples"].values()]
    assert sorted(baked) == sorted((c, f) for c in plan["cameras"] for f in plan["frames"])
    assert _far([f for _c, f in baked], plan["test_frames"])  # the baked folder's own metadata
    rep = checkpoint.load(shot_fit["model"])["fit"]
    assert rep["views"]["test"] == [] and rep["views"]["val"]
    val_cams = {m["samples"][k]["camera"] for k in rep["views"]["val"]}
    assert val_cams and all(plan["cameras"][c] == "val" for c in val_cams)


def test_a_shot_fit_of_rough_surfaces_learns_the_diffuse_part_and_bakes_no_rest(shot_fit):
    """The shot has no mirror or metal (pipeline.fit.has_glossy): its views hold neither EEVEE's rest nor its Glossy
    Color, the fitted model learns Cycles' diffuse part (composed as prediction + the node's rest), and no
    reflection map is written or reported."""
    from ssgi.model import channels as ch
    from ssgi.model.dataset import folder as data_folder
    from ssgi.model.evaluate import fit_report
    from ssgi.model.infer import reflmap as rm
    work = shot_fit["dir"] / "shot.fit"
    plan = json.loads((work / "views_plan.json").read_text())
    assert "rest_samples" not in plan
    (views,) = [p for p in work.glob("views-*") if p.is_dir()]
    m = data_folder.open_folder(views, scenes=True)
    assert not {"rest", "gloss"} & set(data_folder.stored_groups(m)) and "rest" not in m["settings"]["eevee"]
    ck = checkpoint.load(shot_fit["model"])
    assert ck["arch"]["target"] == ch.DIFFUSE_TARGET and ch.base_group(ck["arch"]["target"]) == "rest"
    assert not rm.path_for(shot_fit["model"]).exists()
    assert "reflmap" not in json.loads(fit_report.report_paths(shot_fit["model"])[0].read_text())


def test_fit_shot_report_scores_exactly_the_withheld_frames(shot_fit):
    from ssgi.model.evaluate import fit_report
    s = shot_fit["summary"]
    assert s["ok"] and s["status"] == "done"
    jpath, mpath = fit_report.report_paths(shot_fit["model"])
    rep = json.loads(jpath.read_text())
    w = rep["withheld"]
    want = [3, 7, 11, 14, 18]
    assert w["frames"] == want and w["size"] == [64, 36] and w["ref_samples"] == 2
    lam = rep["lightmap"]["lam"]  # the shot's lightmap (test below): with a weight > 0 the network alone is scored too
    assert list(w["methods"]) == ["fitted"] + (["fitted_network"] if lam > 0 else []) + [
        "generic", "eevee_gi", "cycles_1spp_oidn", "oracle_diffuse"]  # eevee_gi: EEVEE's own render
    for m, r in w["methods"].items():
        assert sorted(map(int, r["per_frame"])) == want and 5 < r["psnr"] < 80
        assert (r["seconds"] is None) == (m == "oracle_diffuse")
    # pooled PSNR lies within the per-frame range (one pool over exactly those frames)
    for r in w["methods"].values():
        assert min(r["per_frame"].values()) - 1e-6 <= r["psnr"] <= max(r["per_frame"].values()) + 1e-6
    assert rep["verdict"] == s["verdict"] == fit_report.withheld_verdict(w) and "3, 7, 11, 14, 18" in rep["verdict"]
    assert "## Withheld frames" in mpath.read_text()
    # a shot fit with a starting checkpoint fine-tunes it alone, towards the shot bar (pipeline.fit.shot_defaults)
    assert [r["name"] for r in rep["rows"] if r["phase"] == "size"] == ["generic-ft"]
    assert rep["target_psnr"] == fit_report.SHOT_BAR_DB
    sheets = sorted(p.name for p in (shot_fit["dir"] / "shot.fit" / "withheld").glob("*.png"))
    assert sheets == [f"frame_{f:04d}.png" for f in want]
    assert s["withheld_minutes"] > 0 and s["total_minutes"] > 0


def test_fit_shot_fits_a_lightmap_and_the_node_blends_it(shot_fit, tmp_path):
    """The shot's lightmap (model/infer/lightmap.py): the fit stores every view's camera matrices, which place a
    world point where Blender's own camera projection does; it writes the lightmap beside the model with a weight
    chosen on the validation views; and the node's render path blends a model's lightmap exactly where it may
    (weight x albedo x light + the rest), keeping the network's image elsewhere."""
    import shutil

    import numpy as np

    from ssgi.model.evaluate import fit_report
    from ssgi.model.infer import lightmap as lm
    from ssgi.model.learn import lightmap as llm
    work = shot_fit["dir"] / "shot.fit"
    (views,) = [p for p in work.glob("views-*") if p.is_dir()]
    cams = json.loads((views / "cameras.json").read_text())
    from ssgi.model.dataset import folder as data_folder
    m = data_folder.open_folder(views, scenes=True)
    assert sorted(cams) == sorted(m["samples"])
    key, meta = sorted(m["samples"].items())[-1]
    got = tmp_path / "proj.json"
    run_py(f'''
import bpy, json
from bpy_extras.object_utils import world_to_camera_view
bpy.ops.wm.open_mainfile(filepath={str(sorted(work.glob("views-*.blend"))[0])!r})
sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 36, 100
sc.frame_set({int(meta["frame"])})
cam = sc.objects[{meta["camera"]!r}]
pts = [list(o.matrix_world.translation) for o in sc.objects if o.type == "MESH"]
json.dump(dict(pts=pts, ndc=[list(world_to_camera_view(sc, cam, __import__("mathutils").Vector(p))) for p in pts]),
          open({str(got)!r}, "w"))
''', timeout=120)
    d = json.loads(got.read_text())
    u, v, z = lm.project(np.array(d["pts"]), cams[key]["M"], cams[key]["P"], 64, 36)
    ndc = np.array(d["ndc"])  # Blender: x right 0..1, y up 0..1, z the depth along the view axis
    assert np.abs(u - (ndc[:, 0] * 64 - 0.5)).max() < 1e-3 and np.abs(v - ((1 - ndc[:, 1]) * 36 - 0.5)).max() < 1e-3
    assert np.allclose(z, ndc[:, 2], rtol=1e-5)
    # the fit's lightmap and its report
    rep = json.loads(fit_report.report_paths(shot_fit["model"])[0].read_text())["lightmap"]
    assert rep["lam"] in llm.LAMBDAS and sorted(map(float, rep["val_psnr"])) == sorted(llm.LAMBDAS)
    assert rep["val_psnr"][str(rep["lam"])] >= max(rep["val_psnr"].values()) - llm.TIE_DB and rep["points"] > 1000
    assert all(v < max(rep["val_psnr"].values()) - llm.TIE_DB for k, v in rep["val_psnr"].items() if float(k) > rep["lam"])
    # with direct light among the model's inputs both fields were tried (the whole light; the light minus it)
    assert "none" in rep["tried"] and rep["tried"]["+".join(rep["known"]) or "none"]["lam"] == rep["lam"]
    assert "## Shot lightmap" in fit_report.report_paths(shot_fit["model"])[1].read_text()
    field = lm.Lightmap.load(lm.path_for(shot_fit["model"]))
    assert field.lam == rep["lam"] and rep["file"] == str(lm.path_for(shot_fit["model"]))
    # the node: a copy of the model with a lightmap of weight 1 that answers 0.5 everywhere
    model = tmp_path / "lm.pt"
    shutil.copy(shot_fit["model"], model)
    din = 6 + 6 * lm.NFREQ
    lm.Lightmap([(np.zeros((3, din)), np.full(3, 0.5))], [0, 0, 0], [1, 1, 1], lm.NFREQ, 1.0).save(lm.path_for(model))
    # and one that learned the light minus the frame's soft direct light (a field of 0.05 added to that pass)
    model2 = tmp_path / "lm2.pt"
    shutil.copy(shot_fit["model"], model2)
    lm.Lightmap([(np.zeros((3, din)), np.full(3, 0.05))], [0, 0, 0], [1, 1, 1], lm.NFREQ, 1.0,
                known=("direct_soft",)).save(lm.path_for(model2))
    out = tmp_path / "node.npz"
    run_py(f'''
import bpy, numpy as np
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession, compose
bpy.ops.wm.open_mainfile(filepath={str(shot_fit["blend"])!r})
sc = bpy.context.scene
setup_scene(sc, {str(model)!r})
s = RenderSession(sc, frames=[10], model={str(model)!r}, write=False, keep_groups=True)
assert s.lightmap is not None and s.lightmap.lam == 1.0
info = next(s.iter_frames())
g = info["groups"]
net = compose(s.predict_network(g), g, sc.camera.data.clip_end, s.target)
s2 = RenderSession(sc, frames=[10], model={str(model2)!r}, write=False, keep_groups=True)
assert s2.lightmap.known == ("direct_soft",) and "direct_soft" in s2.groups
i2 = next(s2.iter_frames())
np.savez({str(out)!r}, img=info["prediction"], net=net, img2=i2["prediction"], ds=i2["groups"]["direct_soft"],
         **{{k: g[k] for k in ("albedo", "depth", "normal", "rest")}})
''', timeout=600)
    r = np.load(out)
    g = {k: r[k] for k in ("albedo", "depth", "normal")}
    w = lm.blend_weight(g, 1.0) > 0
    assert 0.2 < w.mean() < 1.0  # the faces are blended (edges too), the sky is not
    expect = np.maximum(r["rest"][..., :3] + 0.5 * r["albedo"][..., :3], 0)
    assert np.abs(r["img"][w] - expect[w]).max() < 1e-4
    assert np.abs(r["img"][~w] - r["net"][~w]).max() < 1e-5
    assert np.abs(r["net"][w] - expect[w]).mean() > 0.01  # the lightmap changed what the network alone shows
    # the known-light field: albedo x (the frame's own direct_soft + 0.05) where blended, the network elsewhere
    expect2 = r["rest"][..., :3] + r["albedo"][..., :3] * np.maximum(r["ds"][..., :3] + 0.05, 0)
    assert np.abs(r["img2"][w] - expect2[w]).max() < 1e-4 and r["ds"][..., :3][w].std() > 0.01
    assert np.abs(r["img2"][~w] - r["net"][~w]).max() < 1e-5


def test_fit_shot_bad_frame_ranges_are_one_line_errors(shot_fit, tmp_path):
    out = tmp_path / "m.pt"
    for frames, msg in (("20-1", "the shot ends before it starts (1 < 20)"),
                        ("1-12", "12 frame(s) are too few to withhold 5 frames"),
                        ("1-60", "--frames 1-60: outside scene 'ripple''s frame range 1-20"),
                        ("a-b", "is not a frame range A-B")):
        p = run_cli("fit", "--blend", str(shot_fit["blend"]), "--out", str(out), "--frames", frames, check=False,
                    timeout=120)
        assert p.returncode == 2 and msg in p.stderr and "Traceback" not in p.stderr, (frames, p.stderr[-800:])
    assert not list(tmp_path.iterdir())


def test_fit_panel_passes_the_shot_to_the_fit(shot_fit, tmp_path):
    """The Fit panel's "Fit the Shot": the operator starts ``cli.py fit --frames START-END`` (0: the scene's
    range), and refuses a range outside the scene with the same one-line error, starting nothing."""
    res = tmp_path / "res.json"
    run_py(f'''
import bpy, json, ssgi
from ssgi.ssgi_addon.runtime import jobs
ssgi.register()
r = {{}}
bpy.ops.wm.open_mainfile(filepath={str(shot_fit["blend"])!r})
sc = bpy.context.scene
s = sc.ssgi
s.fit_out = {str(tmp_path / "op.pt")!r}
s.fit_shot = True
s["fit_learn_rest"] = True  # what a file saved with the removed "Learn the Rest" setting stores: it still opens
bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / "old.blend")!r})
bpy.ops.wm.open_mainfile(filepath={str(tmp_path / "old.blend")!r})
sc = bpy.context.scene
s = sc.ssgi
r["kept"] = s.get("fit_learn_rest")
s.fit_frame_end = 60
try:
    r["bad"] = list(bpy.ops.ssgi.fit_scene())
except RuntimeError as e:
    r["bad_error"] = str(e)
r["job_after_bad"] = jobs.get("fit") is not None
s.fit_frame_end = 0
assert bpy.ops.ssgi.fit_scene() == {{"FINISHED"}}
job = jobs.get("fit")
r["cmd"] = job.cmd
bpy.ops.ssgi.cancel_job(job="fit")
job.wait(60)
s.fit_lightmap = False
s.fit_reflmap = False
assert bpy.ops.ssgi.fit_scene() == {{"FINISHED"}}
job = jobs.get("fit")
r["cmd_nolm"] = job.cmd
bpy.ops.ssgi.cancel_job(job="fit")
job.wait(60)
s.fit_one_render = True
assert bpy.ops.ssgi.fit_scene() == {{"FINISHED"}}
job = jobs.get("fit")
r["cmd_one"] = job.cmd
bpy.ops.ssgi.cancel_job(job="fit")
job.wait(60)
from tests import ui_recorder
from ssgi.panels.fit_panel import SSGI_PT_fit
r["props"] = ui_recorder.draw(SSGI_PT_fit).props()
s.fit_shot = False
r["props_off"] = ui_recorder.draw(SSGI_PT_fit).props()
json.dump(r, open({str(res)!r}, "w"))
''', timeout=300)
    r = json.loads(res.read_text())
    assert "outside scene 'ripple''s frame range 1-20" in r.get("bad_error", "") or r.get("bad") == ["CANCELLED"]
    assert r["job_after_bad"] is False
    i = r["cmd"].index("--frames")
    assert r["cmd"][i + 1] == "1-20"
    assert r["kept"] in (True, 1)  # the old file's stored setting is kept as data and ignored (not passed to the fit)
    assert "--no-lightmap" not in r["cmd"] and "--no-lightmap" in r["cmd_nolm"]  # the shot lightmap: on by default
    assert "--no-reflmap" not in r["cmd"] and "--no-reflmap" in r["cmd_nolm"]  # the reflection map too
    # a one-render fit that reads the render's Combined image (no Diffuse Direct pass in its frames)
    assert "--one-render" in r["cmd_one"] and "--one-render" not in r["cmd"]
    assert "fit_one_render" in r["props"]
    assert {"fit_shot", "fit_frame_start", "fit_frame_end", "fit_lightmap", "fit_reflmap"} <= set(r["props"])
    assert "fit_shot" in r["props_off"] and "fit_frame_start" not in r["props_off"] and "fit_lightmap" not in r["props_off"]
