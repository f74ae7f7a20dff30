"""Fit to Scene, the bpy-free half: model/learn/fit.py, ablation, the fit report, the fit stage's config
and the views' plan. Budgets are seconds; the views are tiny. The Blender half is tests/blender/test_fit.py."""
from __future__ import annotations

import json
import math
import random
from pathlib import Path

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

@pytest.mark.parametrize("variant,over", [("unet_s", {}), ("fssgi", {"width": 16})])
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
    # (eevee_combined, the one-render models' input, has no drop rank: never dropped; nor gloss)
    assert ablation.droppable(ch.INPUT_GROUPS, "residual") == ["direct_soft", "emit_direct", "world", "emission",
                                                                "glow", "scene", "scene_comb", "sky", "surround", "ao", "depth",
                                                                "normal", "lit"]
    assert ablation.droppable(ch.INPUT_GROUPS, "demod") == ["direct_soft", "emit_direct", "world", "emission", "glow",
                                                             "scene", "scene_comb", "sky", "surround", "ao", "depth", "normal",
                                                             "lit", "direct"]
    assert ablation.droppable(ch.INPUT_GROUPS, "residual_combined")[-1] == "direct"  # its head reads eevee_combined
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


def test_fit_stage_config_refuses_bad_settings_before_any_work(tmp_path):
    from ssgi.ssgi_addon.pipeline.fit import FitSceneConfig
    for kw, msg in ((dict(out=str(tmp_path / "m.txt"), data=str(tmp_path)), "must end in .pt"),
                    (dict(out=str(tmp_path / "no" / "m.pt"), data=str(tmp_path)), "does not exist"),
                    (dict(out=str(tmp_path / "m.pt")), "--blend FILE"),
                    (dict(out=str(tmp_path / "m.pt"), data=str(tmp_path), views=3), "at least 4 views"),
                    (dict(out=str(tmp_path / "m.pt"), data=str(tmp_path), init=str(tmp_path / "x.pt")), "no such model"),
                    (dict(out=str(tmp_path / "m.pt"), data=str(tmp_path), rest_samples=4), "with a shot fit"),
                    (dict(out=str(tmp_path / "m.pt"), data=str(tmp_path), frames=(1, 20), reflmap=False,
                          rest_samples=4), "and its reflection map"),
                    (dict(out=str(tmp_path / "m.pt"), data=str(tmp_path), frames=(1, 20), rest_samples=0),
                     "give a positive count")):
        with pytest.raises(UserError, match=msg):
            FitSceneConfig(**kw).check()
    assert not list(tmp_path.iterdir())


def test_view_counts_and_roles():
    from ssgi.ssgi_addon.blender import views as sfit
    assert sfit.view_counts(24, 1, 1) == (1, 23)
    nf, nj = sfit.view_counts(24, 48, 1)
    assert nf == 3 and (1 + nj) * nf >= 24
    assert sfit.view_counts(4, 1, 2) == (1, 3)  # at least 3 jittered cameras (val, test, train)
    with pytest.raises(UserError, match="at least 4 views"):
        sfit.view_counts(3, 1, 1)
    r = sfit.roles(10, random.Random(0))
    assert sorted(r) == ["test"] * 2 + ["train"] * 6 + ["val"] * 2


def test_fit_with_an_empty_ladder_only_fine_tunes_the_starting_checkpoint(views, generic, tmp_path):
    """An empty ladder (a shot fit's, pipeline.fit.shot_defaults): the size search trains the starting checkpoint
    alone (no scratch network); without a checkpoint there is nothing to train, which is a one-line error before any
    training."""
    cfg = fit.FitConfig(data=str(views), out=str(tmp_path / "ft.pt"), train_keys=TRAIN, val_keys=VAL, minutes=0.2,
                        init=str(generic), ladder=[], threads=1, crop=32, batch=8, min_run_s=1.0,
                        bench_size="96x64", bench_repeats=1, command="test")
    res = fit.fit(cfg, log=lambda m: None)
    size = [r for r in res["rows"] if r["phase"] == "size"]
    assert [r["name"] for r in size] == ["generic-ft"] and size[0]["decision"] == "kept"
    cfg = fit.FitConfig(data=str(views), out=str(tmp_path / "none.pt"), train_keys=TRAIN, val_keys=VAL, minutes=0.2,
                        ladder=[], threads=1, crop=32, batch=8, min_run_s=1.0, command="test")
    with pytest.raises(UserError, match="the size ladder is empty"):
        fit.fit(cfg, log=lambda m: None)
    assert not (tmp_path / "none.pt").exists()


def test_a_shot_fit_fine_tunes_the_starting_checkpoint_towards_the_shot_bar(tmp_path):
    from ssgi.model.evaluate.fit_report import SHOT_BAR_DB
    from ssgi.ssgi_addon.pipeline.fit import FitSceneConfig, shot_defaults
    cfg = FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path))
    assert shot_defaults(cfg, "generic.pt", shot=True) == ([], SHOT_BAR_DB) and SHOT_BAR_DB == 35.0
    assert shot_defaults(cfg, "generic.pt", shot=False) == (None, None)  # a still scene: the ladder, generic + 2 dB
    assert shot_defaults(cfg, None, shot=True) == (None, None)  # nothing to fine-tune: the scratch ladder
    told = FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path), target_psnr=30.0)
    assert shot_defaults(told, "generic.pt", shot=True) == ([], 30.0)  # the fine-tune alone, towards the given PSNR
    assert shot_defaults(told, "generic.pt", shot=False) == (None, 30.0)


def test_cli_fit_has_no_size_ladder_or_rest_target_option():
    """A still scene searches model.learn.fit.LADDER and a shot fit fine-tunes its start: there is no option to
    give a ladder, nor to learn Cycles' image minus EEVEE's rest."""
    import argparse

    from ssgi.ssgi_addon.commands import fit as cfit
    parser = argparse.ArgumentParser()
    cfit.register_cli(parser.add_subparsers())
    p = parser.parse_args(["fit", "--out", "m.pt", "--blend", "a.blend"])
    assert not hasattr(p, "ladder") and not hasattr(p, "learn_rest")
    for gone in ("--ladder", "--learn-rest"):
        with pytest.raises(SystemExit):
            parser.parse_args(["fit", "--out", "m.pt", "--blend", "a.blend", gone, "[]"])


# ---- views that hold EEVEE's rest (a glossy shot's, for its reflection map)

def test_a_model_that_learned_the_rest_target_is_refused_in_one_line_naming_the_fit_to_run(generic, tmp_path):
    """Target ref_minus_rest (Cycles' image minus EEVEE's rest) is no longer learned: a checkpoint or an ONNX export
    of such a model is refused with one line saying to fit it again, never a traceback."""
    import types

    from ssgi.model.infer import onnx as ort_backend
    ck = checkpoint.load(generic)
    ck["arch"] = dict(ck["arch"], target="ref_minus_rest")
    path = tmp_path / "rest.pt"
    checkpoint.save(path, ck)
    for load in (checkpoint.load, predictor.load_predictor):
        with pytest.raises(UserError) as e:
            load(path)
        msg = str(e.value)
        assert msg.startswith(f"{path}: was fitted to learn Cycles' image minus EEVEE's rest (target 'ref_minus_rest'), "
                              "which SSGI no longer does; fit it again with `cli.py fit`") and "\n" not in msg
    meta = {"ssgi_onnx": json.dumps(ort_backend.ONNX_VERSION), "inputs": json.dumps(["albedo", "normal"]),
            "arch": json.dumps({"target": "ref_minus_rest"}), "multiple": "8", "receptive_field": "45"}
    sess = types.SimpleNamespace(get_modelmeta=lambda: types.SimpleNamespace(custom_metadata_map=meta))
    with pytest.raises(UserError, match=r"rest.onnx: was fitted to learn .*fit it again with `cli.py fit`"):
        ort_backend.read_meta(sess, "rest.onnx")
    with pytest.raises(UserError, match="target 'ref_minus_rest' .* no longer learns; fit it again with `cli.py fit`"):
        ch.check_target("ref_minus_rest")
    assert "ref_minus_rest" not in ch.TARGETS


@pytest.fixture(scope="module")
def rest_views(tmp_path_factory):
    return synthetic.make_dataset(tmp_path_factory.mktemp("rviews"), scenes=1, per_scene=10, w=48, h=32, seed=4,
                                  rest=True)


def test_a_fit_on_views_with_eevees_rest_scores_the_node_image_prediction_plus_rest(rest_views, generic, tmp_path):
    """Views that hold EEVEE's rest (a glossy shot's): the fit learns Cycles' diffuse part, the report's val PSNR is
    its own against that part, and the node score composes its prediction with the view's rest against Cycles'
    whole image."""
    from ssgi.model.infer import compose
    out = tmp_path / "diffuse.pt"
    cfg = fit.FitConfig(data=str(rest_views), out=str(out), train_keys=TRAIN, val_keys=VAL, test_keys=TEST,
                        minutes=0.2, init=str(generic), ladder=[], threads=1, crop=32, batch=8, min_run_s=1.0,
                        drop_tol=-math.inf, bench_size="96x64", bench_repeats=1, command="test")
    res = fit.fit(cfg, log=lambda m: None)
    ck = checkpoint.load(out)
    assert ck["arch"]["target"] == ch.DIFFUSE_TARGET
    net = checkpoint.build_net(ck)
    v = data.StoredSamples(rest_views, KEYS)
    own = evaluate(net, v.samples(tuple(ck["inputs"]), VAL, target=ch.DIFFUSE_TARGET))["val_psnr"]
    assert own == pytest.approx(res["final"]["val"]["psnr"], abs=1e-6)
    pred = predictor.load_predictor(out)
    se, n = 0.0, 0
    for k in TEST:
        g = v.raw[k]
        m = images.geometry_mask(g["depth"], g["normal"])
        img = np.clip(compose.compose(pred.predict(g), g, pred.target)[m], 0, 1)
        ref = np.clip(g["ref"][..., :3][m], 0, 1)
        se, n = se + float(((img.astype(np.float64) - ref) ** 2).sum()), n + img.size
    assert 10 * math.log10(n / se) == pytest.approx(res["final"]["test_node"]["psnr"], abs=1e-4)


def test_a_fit_refuses_a_whole_image_target_and_views_without_its_targets_groups(views, generic, tmp_path):
    kw = dict(train_keys=TRAIN, val_keys=VAL, minutes=0.1, init=str(generic), ladder=[], threads=1, crop=32, batch=8,
              min_run_s=1.0, command="test")
    with pytest.raises(UserError, match="a fit learns ref_diffuse .* or ref_combined"):
        fit.FitConfig(data=str(views), out=str(tmp_path / "a.pt"), target=ch.TARGET_GROUP, **kw).check()
    with pytest.raises(UserError, match="lack eevee_combined"):
        fit.fit(fit.FitConfig(data=str(views), out=str(tmp_path / "b.pt"), target=ch.COMBINED_TARGET, **kw),
                log=lambda m: None)
    assert not (tmp_path / "b.pt").exists()


def test_inputs_that_are_zero_on_every_view_go_without_a_run():
    """A pass the scene never lights (world in a black world, emission without emitters) is 0 on every view: it
    is dropped before the ablation's runs, and the network that the runs start from computes exactly what the
    full network computed on those views; a pass that is non-zero on one view only is tried as before."""
    torch.manual_seed(2)
    spec = tuple(g for g in ch.INPUT_GROUPS if g in ("albedo", "normal", "depth", "direct", "world", "emission", "lit"))
    net = network.build(network.arch_for("unet_s", spec)).eval()
    for p in net.parameters():
        torch.nn.init.normal_(p, std=0.2)
    lay = normalize.layout(spec)
    samples = []
    for i in range(3):
        x = torch.rand(ch.input_channels(spec), 16, 24)
        x[lay["world"]] = 0
        x[lay["emission"]] = 0
        if i == 1:
            x[lay["emission"]][0, 3, 5] = 1e-3  # one lit pixel on one view: not silent
        samples.append(data.Sample(str(i), "s", x, torch.zeros(3, 16, 24)))
    assert ablation.silent_groups(spec, samples) == ["world"]
    small_spec = tuple(g for g in spec if g != "world")
    kept = [i for g in small_spec for i in range(lay[g].start, lay[g].stop)]
    runs = []

    def train(name, arch, sp, seconds, init_state):
        runs.append((name, tuple(sp)))
        n = network.build(dict(arch)).eval()
        n.load_state_dict(init_state)
        if name == "control":  # starts from the full network with world cut out: the same outputs on these views
            with torch.inference_mode():
                for s in samples:
                    want = net(s.x[None]).numpy()
                    np.testing.assert_allclose(n(s.x[None, kept]).numpy(), want, rtol=1e-4,
                                               atol=1e-5 * np.abs(want).max())
        return n, dict(val_psnr=30.0 - (2.0 if "emission" in name else 0.0), minutes=0.01)

    rows = []
    out, out_spec, control = ablation.select_inputs(net, train, 1.0, 0.1, rows, lambda m: None, silent=["world"])
    assert all("world" not in sp for _, sp in runs) and not any("world" in name for name, _ in runs)
    assert ("drop-emission", tuple(g for g in small_spec if g != "emission")) in runs  # tried: lit on one view
    assert "world" not in out_spec and "emission" in out_spec  # world gone for free; emission costs 2 dB: kept
    assert control == 30.0
    world = next(r for r in rows if r["group"] == "world")
    assert world["decision"].startswith("dropped (0 on every view")


def test_the_start_probe_goes_on_with_the_starting_checkpoint_best_on_the_val_views(views, generic, tmp_path):
    """``also_init``: each starting checkpoint is fine-tuned briefly; the one with the best val PSNR goes on (from
    its probe weights) as the fine-tune candidate; the report's generic model stays ``init``. A checkpoint made
    to be bad on these views (every weight scaled up: outputs far off) must lose the probe."""
    torch.manual_seed(5)
    bad = network.build(network.arch_for("unet_s"))
    with torch.no_grad():
        for p in bad.parameters():
            p.mul_(6.0)
    bad_path = tmp_path / "bad.pt"
    ck = checkpoint.make(bad, "network", command="test")
    ck["versions"] = {k: str(v) for k, v in ck["versions"].items()}
    checkpoint.save(bad_path, ck)
    for order in ((str(generic), [str(bad_path)]), (str(bad_path), [str(generic)])):
        out = tmp_path / f"probe_{len(order[0])}_{Path(order[0]).stem}.pt"
        cfg = fit.FitConfig(data=str(views), out=str(out), train_keys=TRAIN, val_keys=VAL, minutes=0.3,
                            init=order[0], also_init=order[1], ladder=[], threads=1, crop=32, batch=8, min_run_s=1.0,
                            bench_size="96x64", bench_repeats=1, command="test")
        res = fit.fit(cfg, log=lambda m: None)
        size = [r for r in res["rows"] if r["phase"] == "size"]
        probes = [r for r in size if r["name"].startswith("probe ")]
        assert len(probes) == 2 and all(r["val_psnr"] is not None for r in probes)
        best = max(probes, key=lambda r: r["val_psnr"])
        assert [r["decision"].startswith("start probe: goes on") for r in probes].count(True) == 1
        assert best["decision"].startswith("start probe: goes on") and str(generic) in best["decision"]
        kept = next(r for r in size if r["decision"] == "kept")
        assert kept["start"].endswith("after its probe")
        assert res["generic"]["path"] == order[0]  # the report compares with init, whichever start went on


def test_a_fit_start_that_is_not_a_model_is_a_one_line_error(tmp_path):
    from ssgi.ssgi_addon.pipeline.fit import FitSceneConfig
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a checkpoint")
    with pytest.raises(UserError, match="--also-init .*junk.pt"):
        FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path), also_init=[str(junk)]).check()


def test_a_shot_fit_without_init_probes_the_shipped_fit_start_and_nothing_else_does(tmp_path):
    from ssgi.ssgi_addon.pipeline.fit import FIT_START_MODEL, FitSceneConfig, starts_to_probe
    DEFAULT_MODEL = FIT_START_MODEL.with_name("ssgi_default.pt")  # (the node's DEFAULT_MODEL; node imports bpy)
    assert FIT_START_MODEL.is_file() and checkpoint.load(FIT_START_MODEL)["arch"]["variant"]  # shipped, loadable
    meta = json.loads(FIT_START_MODEL.with_suffix(".json").read_text())
    assert meta["model"] == FIT_START_MODEL.name and meta["recipe"]["train"]  # reproducible: its commands beside it
    cfg = FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path))
    assert starts_to_probe(cfg, str(DEFAULT_MODEL), shot=True) == [str(FIT_START_MODEL)]
    assert starts_to_probe(cfg, str(DEFAULT_MODEL), shot=False) == []  # a still scene: the ladder, as before
    mine = FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path), init=str(DEFAULT_MODEL))
    assert starts_to_probe(mine, str(DEFAULT_MODEL), shot=True) == []  # --init given: that start alone
    off = FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path), also_init=[])
    assert starts_to_probe(off, str(DEFAULT_MODEL), shot=True) == []  # --also-init none
    same = FitSceneConfig(out=str(tmp_path / "m.pt"), data=str(tmp_path), also_init=[str(DEFAULT_MODEL), "x.pt"])
    assert starts_to_probe(same, str(DEFAULT_MODEL), shot=True) == ["x.pt"]  # never init itself
