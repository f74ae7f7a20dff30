"""Fit to Scene (issue 8): model/fit.py (bpy-free), cli.py fit, the SSGI node rendering a fitted model, the
Fit to Scene operator. Budgets are seconds; the views are tiny."""
from __future__ import annotations

import json
import math
import random

import numpy as np
import pytest
import torch

from ssgi.model import channels as ch
from ssgi.model.evaluate import fit_report
from ssgi.model.learn import ablation, checkpoint, data, fit, network
from ssgi.model.infer import predictor
from ssgi.model import images, normalize
from ssgi.model.dataset import synthetic
from ssgi.model.errors import UserError
from ssgi.model.learn.train import TrainConfig, Trainer
from ssgi.model.learn.validation import evaluate

from .conftest import clean, run_cli, run_py

ABLATE_ALL = 1000.0  # a drop tolerance that drops every group the head does not need


@pytest.fixture(scope="module")
def views(tmp_path_factory):
    """One synthetic 'scene' seen from 10 view points (camera 0..9), 48x32."""
    return synthetic.make_dataset(tmp_path_factory.mktemp("views"), scenes=1, per_scene=10, w=48, h=32, seed=3)


@pytest.fixture(scope="module")
def generic(tmp_path_factory):
    torch.manual_seed(0)
    net = network.build(network.arch_for("unet_s"))
    path = tmp_path_factory.mktemp("generic") / "generic.pt"
    ck = checkpoint.make(net, "network", command="tests/test_fit.py")
    ck["versions"] = {k: str(v) for k, v in ck["versions"].items()}
    checkpoint.save(path, ck)
    return path


KEYS = [f"{i:06d}" for i in range(10)]
TRAIN, VAL, TEST = KEYS[:6], KEYS[6:8], KEYS[8:]


@pytest.fixture(scope="module")
def fitted(tmp_path_factory, views, generic):
    out = tmp_path_factory.mktemp("fit") / "scene.pt"
    events = []
    cfg = fit.FitConfig(data=str(views), out=str(out), train_keys=TRAIN, val_keys=VAL, test_keys=TEST, minutes=0.45,
                        init=str(generic), threads=1, crop=32, batch=8, drop_tol=ABLATE_ALL, min_run_s=1.0,
                        bench_size="96x64", bench_repeats=2, command="test")
    res = fit.fit(cfg, log=lambda m: None, callback=events.append)
    return dict(out=out, res=res, events=events, cfg=cfg)


# ------------------------------------------------------------------------------------------ bpy-free parts

@pytest.mark.parametrize("variant,over", [("unet_s", {}), ("lean", {}), ("fssgi", {"width": 16})])
def test_drop_inputs_equals_the_old_network_with_those_inputs_at_zero(variant, over):
    torch.manual_seed(1)
    spec = ch.INPUT_GROUPS
    net = network.build(network.arch_for(variant, spec, **over)).eval()
    for p in net.parameters():  # no zero weights anywhere: a wrong column would show
        torch.nn.init.normal_(p, std=0.2)
    x = torch.rand(1, ch.input_channels(spec), 20, 28)
    for drop in (("ao",), ("depth", "normal"), ("lit", "ao", "normal")):
        new_spec = tuple(g for g in spec if g not in drop)
        small = ablation.drop_inputs(net, new_spec).eval()
        assert tuple(small.arch["inputs"]) == new_spec
        lay = normalize.layout(spec)
        kept = [i for g in new_spec for i in range(lay[g].start, lay[g].stop)]
        zeroed = x.clone()
        for g in drop:
            zeroed[:, lay[g]] = 0
        with torch.inference_mode():
            want = net(zeroed).numpy()  # equal up to float summation order (outputs reach ~50 here)
            np.testing.assert_allclose(small(x[:, kept]).numpy(), want, rtol=1e-4, atol=1e-5 * np.abs(want).max())
            assert not torch.allclose(net(x), net(zeroed))  # the dropped inputs did matter before
    with pytest.raises(UserError, match="not a sub-sequence"):
        ablation.drop_inputs(net, ("direct", "albedo"))


def test_droppable_respects_the_head():
    assert ablation.droppable(ch.INPUT_GROUPS, "residual") == ["world", "scene", "ao", "depth", "normal", "lit"]
    assert ablation.droppable(ch.INPUT_GROUPS, "demod") == ["world", "scene", "ao", "depth", "normal", "lit", "direct"]
    assert ablation.droppable(("albedo", "direct"), "residual") == []


def test_split_views_holds_out_whole_cameras():
    by_cam = {"Camera": ["000000", "000003"], "v1": ["000001", "000004"], "v2": ["000002"], "v3": ["000005"]}
    tr, va, te = fit.split_views(by_cam, test_cameras=["v2"], val_cameras=["v1", "v3"])
    assert tr == ["000000", "000003"] and va == ["000001", "000004", "000005"] and te == ["000002"]


def test_config_refuses_overlapping_or_empty_splits(views):
    with pytest.raises(UserError, match="disjoint"):
        fit.FitConfig(data=str(views), out="m.pt", train_keys=TRAIN, val_keys=TRAIN[:1]).check()
    with pytest.raises(UserError, match="held-out validation"):
        fit.FitConfig(data=str(views), out="m.pt", train_keys=TRAIN, val_keys=[]).check()
    with pytest.raises(UserError, match="minutes"):
        fit.FitConfig(data=str(views), out="m.pt", train_keys=TRAIN, val_keys=VAL, minutes=0).check()


def test_fit_trainer_uses_the_given_views_and_starting_weights(views, generic, tmp_path):
    v = data.StoredSamples(views, KEYS)
    ds = v.dataset(ch.DEFAULT_INPUTS, TRAIN + VAL)
    ck = checkpoint.load(generic)
    cfg = TrainConfig(data=str(views), out=str(tmp_path / "t.pt"), variant="unet_s", inputs=ch.format_spec(ch.DEFAULT_INPUTS),
                      epochs=1, crop=32, batch=4, command="test")
    tr = Trainer(cfg, ds, split=(TRAIN, VAL), init_state=ck["state_dict"], log=lambda m: None)
    tr._setup()
    assert [s.key for s in tr.train_set] == TRAIN and [s.key for s in tr.val_set] == VAL
    for k, w in ck["state_dict"].items():
        assert torch.equal(tr.net.state_dict()[k], w), k


def test_views_build_inputs_as_the_render_path_does(views, tmp_path):
    """A spec that keeps depth but drops normals: the input is what the node's render path computes (the
    spec's groups plus the normals, which mark the background for the depth normalisation)."""
    from ssgi.model.dataset import exrio
    from ssgi.model import normalize
    spec = ("albedo", "depth", "direct")
    g = exrio.read_sample(views / "000000.exr")
    g["normal"][:4] = 0  # nothing hit in the top rows: background for depth only when normals are used
    d = synthetic.make_dataset(tmp_path / "v", scenes=1, per_scene=1, w=48, h=32, seed=3)
    exrio.write_sample(d / "000000.exr", g)
    g = exrio.read_sample(d / "000000.exr")  # as stored (half floats)
    s = data.StoredSamples(d, KEYS[:1]).samples(spec, KEYS[:1])[0]
    want, _ = normalize.to_inputs({k: g[k] for k in ("albedo", "depth", "direct", "normal")}, spec)
    np.testing.assert_array_equal(s.x.permute(1, 2, 0).numpy(), want)
    without, _ = normalize.to_inputs({k: g[k] for k in ("albedo", "depth", "direct")}, spec)
    assert not np.array_equal(want, without)


# ------------------------------------------------------------------------------------------ one whole fit

def test_fit_writes_a_checkpoint_with_only_the_kept_inputs(fitted):
    ck = checkpoint.load(fitted["out"])
    # every group the residual head does not need was dropped (tolerance ABLATE_ALL)
    assert tuple(ck["inputs"]) == ("albedo", "direct") == tuple(ck["arch"]["inputs"])
    pred = predictor.load_predictor(fitted["out"])
    assert pred.required == ("albedo", "direct")
    assert fitted["res"]["passes"] == ["use_pass_diffuse_color", "use_pass_diffuse_direct"]
    # the report is in the checkpoint and beside it, and they agree
    rep = ck["fit"]
    jpath, mpath = fit_report.report_paths(fitted["out"])
    assert json.loads(jpath.read_text())["final"] == rep["final"]
    md = mpath.read_text()
    assert "## Size search" in md and "## Inputs" in md and rep["verdict"] in md
    assert rep["views"]["val"] == VAL and rep["views"]["test"] == TEST


def test_fit_report_numbers_are_the_models_own(fitted, views):
    """The test PSNR in the report is what the saved checkpoint scores on the test views, recomputed here;
    the generic model's too."""
    ck = checkpoint.load(fitted["out"])
    rep = ck["fit"]
    v = data.StoredSamples(views, KEYS)
    net = checkpoint.build_net(ck)
    got = evaluate(net, v.samples(tuple(ck["inputs"]), TEST))["val_psnr"]
    assert got == pytest.approx(rep["final"]["test"]["psnr"], abs=1e-6)
    gck = checkpoint.load(fitted["cfg"].init)
    gnet = checkpoint.build_net(gck)
    gv = evaluate(gnet, v.samples(tuple(gck["inputs"]), TEST))["val_psnr"]
    assert gv == pytest.approx(rep["generic"]["test"]["psnr"], abs=1e-6)

    # as the node shows them: the saved models loaded the node's way, each test view predicted from its
    # stored groups, MSE pooled over the geometry pixels
    def node_psnr(path):
        pred = predictor.load_predictor(path)
        se, n = 0.0, 0
        for k in TEST:
            g = v.raw[k]
            m = images.geometry_mask(g["depth"], g["normal"])
            out, ref = np.clip(pred.predict(g)[m], 0, 1), np.clip(normalize.target(g)[m], 0, 1)
            se, n = se + float(((out.astype(np.float64) - ref) ** 2).sum()), n + out.size
        return 10 * math.log10(1 / (se / n))

    got_n, gv_n = node_psnr(fitted["out"]), node_psnr(fitted["cfg"].init)
    assert got_n == pytest.approx(rep["final"]["test_node"]["psnr"], abs=1e-4)
    assert gv_n == pytest.approx(rep["generic"]["test_node"]["psnr"], abs=1e-4)
    # the verdict judges what the node shows
    assert ("does not gain" in rep["verdict"]) == (got_n - gv_n < fit.TARGET_GAIN_DB or
                                                   rep["final"]["ms_big"] > 0.5 * rep["generic"]["ms_big"])
    assert f"{got_n:.2f} dB" in rep["verdict"] and f"{gv_n:.2f} dB" in rep["verdict"]


def test_fit_size_search_is_smallest_first_and_keeps_the_first_to_reach_the_target(fitted):
    rep = checkpoint.load(fitted["out"])["fit"]
    size = [r for r in rep["rows"] if r["phase"] == "size"]
    macs = [r["macs_per_px"] for r in size]
    assert macs == sorted(macs) and len(size) == len(fit.LADDER) + 1  # the ladder and the generic fine-tune
    assert any(r["start"] == "fine-tune" for r in size)
    tried = [r for r in size if r.get("val_psnr") is not None]
    assert tried, size
    kept = [r for r in size if r["decision"] == "kept"]
    assert len(kept) == 1
    t = rep["target_psnr"]
    assert t == pytest.approx(rep["generic"]["val"]["psnr"] + fit.TARGET_GAIN_DB)
    if rep["target_reached"]:
        first = next(r for r in tried if r["val_psnr"] >= t)
        assert kept[0] is first or kept[0]["name"] == first["name"]
        assert all(r.get("val_psnr") is None for r in size[size.index(kept[0]) + 1:])  # larger ones not trained
    else:
        assert kept[0]["val_psnr"] == max(r["val_psnr"] for r in tried)
    final = rep["final"]
    assert final["arch"] == kept[0]["arch"]


def test_fit_ablation_decisions_follow_the_numbers(fitted):
    rep = checkpoint.load(fitted["out"])["fit"]
    rows = [r for r in rep["rows"] if r["phase"] == "inputs"]
    control = next(r for r in rows if r["decision"] == "control")
    assert control["val_psnr"] == pytest.approx(rep["control_val_psnr"])
    singles = [r for r in rows if r["group"] in ("ao", "depth", "normal", "lit")]
    assert sorted(r["group"] for r in singles) == ["ao", "depth", "lit", "normal"]
    for r in singles:
        assert r["delta_db"] == pytest.approx(control["val_psnr"] - r["val_psnr"], abs=1e-9)
        assert r["decision"] == "dropped"  # tolerance ABLATE_ALL
        assert "normal" not in r["spec"].split(",") or r["group"] != "normal"
    assert [r["decision"] for r in rows if r["group"] in ("albedo", "direct")] == ["kept (the residual head needs it)"] * 2


def test_fit_progress_reports_phases_in_order(fitted):
    phases = [e["phase"] for e in fitted["events"]]
    seen = list(dict.fromkeys(phases))
    assert seen == ["size", "inputs", "polish", "done"] or seen == ["size", "inputs", "done"], seen
    ps = [e["progress"] for e in fitted["events"]]
    assert all(0 <= p <= 1 for p in ps) and ps == sorted(ps)


def test_fit_cancel_writes_nothing(views, tmp_path):
    out = tmp_path / "c.pt"
    calls = {"n": 0}

    def stop():
        calls["n"] += 1
        return calls["n"] > 3

    cfg = fit.FitConfig(data=str(views), out=str(out), train_keys=TRAIN, val_keys=VAL, minutes=1.0, threads=1,
                        crop=32, batch=8, min_run_s=1.0, command="test")
    res = fit.fit(cfg, log=lambda m: None, should_stop=stop)
    assert res["status"] == "cancelled" and not out.exists() and not fit_report.report_paths(out)[0].exists()


def test_view_counts_and_roles():
    from ssgi.ssgi_addon.pipeline import fit as sfit
    assert sfit.view_counts(24, 1, 1) == (1, 23)
    nf, nj = sfit.view_counts(24, 48, 1)
    assert nf == 3 and (1 + nj) * nf >= 24
    assert sfit.view_counts(4, 1, 2) == (1, 3)  # at least 3 jittered cameras (val, test, train)
    with pytest.raises(UserError, match="at least 4 views"):
        sfit.view_counts(3, 1, 1)
    r = sfit.roles(10, random.Random(0))
    assert sorted(r) == ["test"] * 2 + ["train"] * 6 + ["val"] * 2


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
    from ssgi.ssgi_addon.pipeline import fit as sfit
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
from ssgi.ssgi_addon.pipeline import fit as sfit
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
    # the node rendered what the model needs (+ depth, normals and EEVEE's colour, which the render path
    # always takes for the world pixels and the depth normalisation), and nothing else (no AO)
    passes = scene_fit["dir"] / "passes" / "000002.exr"
    planes, _ = exrio.read_exr(passes)
    assert {c.split(".")[0] for c in planes} == {"albedo", "direct", "depth", "normal", "eevee"}
    g = exrio.read_sample(passes, groups=("albedo", "direct", "depth", "normal", "eevee"))
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
from ssgi.ssgi_addon.pipeline.fit import group_members
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
