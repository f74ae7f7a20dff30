"""The speed-against-error report: metric functions against known values, the equal-quality
interpolation, and a tiny end-to-end run on real Blender (2 random rooms at 64x36, baked through
`bake --scenes`, a short spp ladder, random-init tiny models), on the command line and from the Report button."""
import json
import math

import pytest

from ssgi.model.learn import checkpoint, network

from ..conftest import ROOT, run_cli, run_py

def test_report_stage_config_refuses_bad_settings_before_any_work(tmp_path):
    from ssgi.model.errors import UserError
    from ssgi.ssgi_addon.pipeline.report import ReportConfig
    m = tmp_path / "m.pt"
    m.write_bytes(b"x")
    for kw, msg in ((dict(models=[str(m)]), "--data DIR"),
                    (dict(models=[str(tmp_path / "nope.pt")], data=str(tmp_path)), "nope.pt: no such file"),
                    (dict(models=[str(m)], data=str(tmp_path / "nowhere")), "no such folder"),
                    (dict(models=[str(m)], data=str(tmp_path), spp=(4, 2)), "ascending"),
                    (dict(models=[str(m)], data=str(tmp_path), split="train"), "--split"),
                    (dict(models=[str(m)], data=str(tmp_path), max_scenes=0), "--max-scenes"),
                    (dict(models=[str(m)], data=str(tmp_path), sizes=()), "--no-scaling")):
        with pytest.raises(UserError, match=msg):
            ReportConfig(out=str(tmp_path / "out"), **kw).check()
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------------------ end to end

_ROOMS = r'''
import sys, bpy
from ssgi.ssgi_addon.blender import room
for seed, path in ((3, sys.argv[1]), (4, sys.argv[2])):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    room.build_room(seed, bpy.context.scene)
    bpy.ops.wm.save_as_mainfile(filepath=path)
'''

TINY = ("--spp", "1,2,4", "--eevee-samples", "1", "--eevee-high-samples", "2", "--threads", "1")


@pytest.fixture(scope="module")
def tiny_models(tmp_path_factory):
    """Random-init checkpoints of three network sizes and a linear model (the weights do not change the work)."""
    import torch
    d = tmp_path_factory.mktemp("models")
    out = []
    for v in ("unet_s", "unet", "fssgi", "linear"):
        torch.manual_seed(0)
        net = network.build(network.arch_for(v)).eval()
        checkpoint.save(d / f"{v}.pt", checkpoint.make(net, "linear" if v == "linear" else "network", command="test"))
        out.append(d / f"{v}.pt")
    return out


@pytest.fixture(scope="module")
def e2e(tmp_path_factory, tiny_models):
    """The report's run over two rooms: the random-init networks of each size, and the two shipped models (what a user
    reports on)."""
    d = tmp_path_factory.mktemp("report")
    models = [*tiny_models, ROOT / "models" / "ssgi_default.pt", ROOT / "models" / "ssgi_one_render.pt"]
    blends = [d / "room3.blend", d / "room4.blend"]
    run_py(_ROOMS, *map(str, blends), timeout=120)
    out = d / "out"
    p = run_cli("report", "--scenes", *map(str, blends), "--models", *map(str, models), "--out", str(out),
                "--size", "64x36", "--ref-samples", "16", *TINY, "--sizes", "64x36,128x72", "--temporal-frames", "3",
                "--json", timeout=600)
    return dict(out=out, summary=json.loads(p.stdout), raw=json.loads((out / "report.json").read_text()),
                stderr=p.stderr, models=models)


def _finite(x) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def test_end_to_end_writes_all_four_outputs_with_finite_numbers(e2e):
    out, raw = e2e["out"], e2e["raw"]
    for name in ("report.md", "report.json", "pareto.png", "examples.png"):
        assert (out / name).stat().st_size > 1000, name
    assert not (out / "report.partial.json").exists()
    from PIL import Image
    w, h = Image.open(out / "pareto.png").size
    assert w > 1000 and h > 400
    assert raw["scenes"] == ["room3:ssgi.camera:1", "room4:ssgi.camera:1"]
    want = {"eevee_direct", "eevee_gi_default", "eevee_gi_high", "reference"}
    want |= {f"cycles_{n}" for n in (1, 2, 4)} | {f"cycles_oidn_{n}" for n in (1, 2, 4)}
    want |= {f"model_{i}_{p.stem}" for i, p in enumerate(e2e["models"])}
    assert set(raw["methods"]) == want
    for k, m in raw["methods"].items():
        s = m["summary"]
        for key in ("psnr", "tm_psnr", "ssim", "flip", "whole_s", "own_s", "worst_psnr"):
            assert _finite(s[key]), (k, key, s[key])
        assert len(m["per_scene"]) == (1 if k == "reference" else 2)
        assert 0 < s["own_s"] <= s["whole_s"] + 1e-9 and -1 <= s["ssim"] <= 1 and 0 <= s["flip"] <= 1
    for k in want - {"reference"} - {f"cycles_{n}" for n in (1, 2, 4)} - {f"cycles_oidn_{n}" for n in (1, 2, 4)}:
        if k.startswith("model_"):  # learned: G-buffer (+ EEVEE's render of the rest) + prediction; own cost = the
            # prediction alone
            t = raw["methods"][k]["summary"]["time"]
            assert t["whole_s"] == pytest.approx(t["gbuffer_s"] + t["predict_s"] + t.get("rest_s", 0.0))
            assert t["own_s"] == t["predict_s"]
            assert _finite(raw["methods"][k]["equal_quality"]["whole"]["speedup"])
    # the physics a wrong program gets wrong: more samples, less error; OIDN beats raw at 1 spp
    cyc = {n: raw["methods"][f"cycles_{n}"]["summary"]["psnr"] for n in (1, 2, 4)}
    assert cyc[1] < cyc[2] < cyc[4]
    assert raw["methods"]["cycles_oidn_1"]["summary"]["psnr"] > cyc[1]
    # the scenes reopened here are the ones the baker rendered
    assert all(v == "inf" or v > 40 for v in raw["gbuffer_agreement_db"].values())
    # params and FLOPs for the learned methods, in size order
    params = [raw["methods"][f"model_{i}_{v}"]["params"] for i, v in enumerate(("unet_s", "unet", "fssgi"))]
    assert params[2] > params[1] > params[0] > 0 and raw["methods"]["model_3_linear"]["params"] == 42
    # scaling and temporal numbers
    sc = raw["scaling"]
    assert sc["sizes"] == ["64x36", "128x72"] and all(
        len(rows) == 2 and all(_finite(r["ms"]) and r["ms"] > 0 for r in rows) for rows in sc["models"].values())
    tp = raw["temporal"]
    assert tp["frames"] == 3 and tp["oidn_spp"] in (1, 2, 4)
    assert all(_finite(r["change"]) and len(r["per_step"]) == 2 for r in tp["methods"].values())
    # the shipped default model is the report's default when it is among the models
    assert e2e["summary"]["ok"] and e2e["summary"]["default_model"] == "model_4_ssgi_default"


def test_report_md_has_the_table_verdicts_and_settings(e2e):
    md = (e2e["out"] / "report.md").read_text()
    for s in ("| EEVEE direct light only |", "| Cycles 4 spp + OIDN |", "SSGI unet_s", "linear regression",
              "## Where the learned methods stand against Cycles + OIDN", "## Scaling", "## Temporal stability",
              "## Settings", "## Machine and versions", "software GL", "cli.py report --scenes"):
        assert s in md, s
    table = md.split("## Methods")[1].split("## Where")[0]
    assert "n/a" not in table and "nan" not in table
    for key in ("model_0_unet_s", "model_4_ssgi_default", "model_5_ssgi_one_render"):
        v = e2e["raw"]["verdicts"][key][0]
        assert v.split(":")[0] in ("wins", "loses", "undecided"), key


def test_dataset_split_follows_the_models_checkpoint(e2e):
    """The default evaluation scenes are the validation scenes a model records for this very dataset."""
    from ssgi.model.dataset import folder
    from ssgi.ssgi_addon.pipeline import report_scenes as rr
    d = e2e["out"] / "data"
    sha = folder.manifest_sha256(d)
    ck = {"dataset": {"manifest_sha256": sha, "split": {"val": ["room4"]}}}
    scenes, over, notes = rr.dataset_scenes(d, [ck])
    assert [s.name for s in scenes] == ["room4"] and over["size"] == (64, 36) and over["ref_samples"] == 16
    assert "validation scenes all 1 model checkpoint(s) record" in notes[0]
    ck2 = {"dataset": {"path": str(d.resolve()), "split": {"val": ["room3", "room4"]}}}  # same folder, grown since
    assert [s.name for s in rr.dataset_scenes(d, [ck, ck2])[0]] == ["room4"]  # trained on by neither model
    ck["dataset"]["manifest_sha256"] = "another dataset"
    scenes, _, notes = rr.dataset_scenes(d, [ck])
    assert len(scenes) == 1 and "split_scenes" in notes[0]  # 2 scenes: one goes to validation
    assert [s.name for s in rr.dataset_scenes(d, [], split="all")[0]] == ["room3", "room4"]
    # a model trained on ANOTHER dataset that held room3 (the same room baked twice): room3 is left out
    other = {"dataset": {"manifest_sha256": "another dataset", "split": {"train": ["room3", "room9"], "val": []}}}
    scenes, _, notes = rr.dataset_scenes(d, [other], split="all")
    assert [s.name for s in scenes] == ["room4"] and any("left out 1 scene(s)" in n and "room3" in n for n in notes)


def test_a_sample_scaled_by_the_removed_stand_in_baker_is_refused(e2e, tmp_path):
    """docs/model_minibake.py (removed) scaled a sample's lights by an ``exposure`` it recorded in the manifest;
    cli.py bake never does. The report refuses such a folder with one line instead of scoring it unscaled."""
    import json
    import shutil

    from ssgi.model.errors import UserError
    from ssgi.ssgi_addon.pipeline import report_scenes as rr
    d = shutil.copytree(e2e["out"] / "data", tmp_path / "data")
    m = json.loads((d / "manifest.json").read_text())
    assert all("exposure" not in s for s in m["samples"].values())  # the baker records none
    key = sorted(m["samples"])[0]
    m["samples"][key]["exposure"] = 2.0
    (d / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(UserError, match=rf"sample {key} records exposure 2.0.*re-bake the folder"):
        rr.dataset_scenes(d, [], split="all")


def test_cli_errors_name_the_fault(tmp_path, tiny_models):
    f = tmp_path / "file.txt"
    f.write_text("x")
    p = run_cli("report", "--data", str(tmp_path), "--models", str(tiny_models[0]), "--out", str(f), check=False)
    assert p.returncode == 2 and "file.txt: is a file, not a folder" in p.stderr and "Traceback" not in p.stderr
    p = run_cli("report", "--data", str(tmp_path), "--models", str(tmp_path / "nope.pt"), "--out", str(tmp_path),
                check=False)
    assert p.returncode == 2 and "nope.pt" in p.stderr and "no such file" in p.stderr
    p = run_cli("report", "--data", str(tmp_path), "--models", str(tiny_models[0]), "--out", str(tmp_path / "o"),
                "--no-fit-baseline", check=False)
    assert p.returncode == 2 and "manifest" in p.stderr and "Traceback" not in p.stderr
    p = run_cli("report", "--data", str(tmp_path), "--models", str(tiny_models[0]), "--out", str(tmp_path / "o"),
                "--spp", "4,2", check=False)
    assert p.returncode == 2 and "ascending" in p.stderr


_STAGE = r'''
import json, sys
from ssgi.ssgi_addon.pipeline import report
data, model, out = sys.argv[1], sys.argv[2], sys.argv[3]
cfg = dict(models=[model], data=data, split="all", max_scenes=1, spp=(1,), eevee_samples=1, eevee_high_samples=1,
           scaling=False, temporal_frames=0, fit_baseline=False)
stopped = report.run(report.ReportConfig(out=out + "/stopped", **cfg), should_stop=lambda: True)
events = []
res = report.run(report.ReportConfig(out=out + "/done", **cfg), progress=events.append)
print("STAGE" + json.dumps(dict(stopped=stopped, res=res, events=events), default=str))
'''


def test_report_stage_runs_from_python_with_progress_and_stop(e2e, tmp_path):
    """The report stage without argparse: a ReportConfig -> pipeline.report.run -> the summary; progress(dict)
    after every step, in order; should_stop() between scenes ends it with report.partial.json and no report."""
    p = run_py(_STAGE, str(e2e["out"] / "data"), str(e2e["models"][0]), str(tmp_path), timeout=400)
    r = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("STAGE"))[len("STAGE"):])
    assert r["stopped"]["cancelled"] is True and r["stopped"]["scenes"] == [] and r["stopped"]["files"] == {}
    assert not (tmp_path / "stopped" / "report.md").exists()
    res = r["res"]
    assert res["cancelled"] is False and res["scenes"] == ["room3"] and (tmp_path / "done" / "report.md").is_file()
    raw = json.loads((tmp_path / "done" / "report.json").read_text())
    assert raw["command"] == "ssgi_addon.pipeline.report.run" and raw["settings"]["spp"] == [1]
    ps = [e["progress"] for e in r["events"]]
    assert len(ps) >= 7 and ps == sorted(ps) and 0 < ps[0] < ps[-1] <= 1 and all(e["phase"] == "report" for e in r["events"])


# ------------------------------------------------------------------------------------------ the Report button

_BUTTON = r'''
import json, sys, time
import bpy
import ssgi
from tests import ui_recorder
bpy.ops.wm.read_factory_settings(use_empty=True)
ssgi.register()
from ssgi.ssgi_addon.runtime import jobs
from ssgi.ssgi_addon.commands import report as report_cli
from ssgi.panels.report_panel import SSGI_PT_report
sc = bpy.context.scene
data, models, out = sys.argv[1], sys.argv[2].split(";"), sys.argv[3]
sc.ssgi.model_path, sc.ssgi.report_models, sc.ssgi.report_out = models[0], ";".join(models[1:]), out
sc.ssgi.report_max_scenes = 1
rep = {}
sc.ssgi.dataset_dir = data + "-missing"
try:
    bpy.ops.ssgi.report()
except RuntimeError as e:
    rep["missing_error"] = str(e)
sc.ssgi.dataset_dir = data
rep["op"] = sorted(bpy.ops.ssgi.report(options="--split all --spp 1 --eevee-samples 1 --eevee-high-samples 1 "
                                               "--no-scaling --temporal-frames 0"))
job = jobs.get("report")
rep["poll_while_running"] = bpy.ops.ssgi.report.poll()
drawn, pumps, t0 = None, 0, time.time()
while job.pump():
    pumps += 1
    if drawn is None and job.state.get("progress", 0) > 0:
        rec = ui_recorder.draw(SSGI_PT_report)
        drawn = {"operators": rec.operators(), "texts": [e["kw"].get("text") for e in rec.log if e["fn"] == "progress"]}
    time.sleep(0.05)
rep["pump_rate"] = pumps / max(time.time() - t0, 1e-6)
rep["state"] = job.state
rep["result"] = job.result
rep["drawn"] = drawn
rec = ui_recorder.draw(SSGI_PT_report)
rep["after"] = {"labels": rec.labels(), "operators": rec.operators()}
print("REPORT" + json.dumps(rep, default=str))
'''


def test_report_button_runs_in_the_background_and_panel_shows_progress(e2e, tmp_path):
    out = tmp_path / "ui_report"
    p = run_py(_BUTTON, str(e2e["out"] / "data"), ";".join(map(str, e2e["models"])), str(out), timeout=400)
    r = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])
    assert "data-missing: dataset folder does not exist" in r["missing_error"]
    assert r["op"] == ["FINISHED"] and r["poll_while_running"] is False
    assert r["state"]["status"] == "done", r["state"]
    assert r["pump_rate"] > 5  # Blender's main thread stayed free while the report ran
    assert r["drawn"]["operators"] == [["ssgi.cancel_job", True]] and "%" in r["drawn"]["texts"][0]
    assert r["result"]["scenes"] == ["room3"]
    for k in ("md", "json", "pareto", "examples"):
        assert (out / f"report.{k}" if k in ("md", "json") else out / f"{k}.png").is_file()
    raw = json.loads((out / "report.json").read_text())
    assert len([k for k in raw["methods"] if k.startswith("model_")]) == len(e2e["models"])
    assert any(l.startswith("Written: ") and l.endswith("report.md") for l in r["after"]["labels"])
    assert ["ssgi.report", True] in r["after"]["operators"]


# ------------------------------------------------------------------------------------------ one-render models

@pytest.fixture(scope="module")
def one_render_models(tmp_path_factory):
    """A random-init one-render checkpoint: a ref_combined model (eevee_combined, ray tracing and fast GI off, emitter
    proxies: what `cli.py fit --one-render` makes)."""
    import torch
    from ssgi.model import channels as ch
    d = tmp_path_factory.mktemp("one_render_models")
    out = []
    for name, variant, inputs, target, over in (
            ("comb", "unet_s", "albedo,normal,depth,emission,eevee_combined,glow,surround", ch.COMBINED_TARGET,
             dict(head="residual_combined")),):
        torch.manual_seed(0)
        net = network.build(network.arch_for(variant, inputs=inputs, target=target, **over)).eval()
        checkpoint.save(d / f"{name}.pt", checkpoint.make(net, "network", command="test"))
        out.append(d / f"{name}.pt")
    return out


def test_the_report_renders_a_one_render_model_from_its_one_render(e2e, one_render_models, tmp_path):
    """A one-render model (what `cli.py fit --one-render` makes) is scored from one EEVEE render (no G-buffer
    renders)."""
    out = tmp_path / "rep"
    run_cli("report", "--data", str(e2e["out"] / "data"), "--split", "all", "--max-scenes", "1",
            "--models", *map(str, one_render_models), "--out", str(out), "--spp", "1", "--eevee-samples", "1",
            "--eevee-high-samples", "1", "--threads", "1", "--no-scaling", "--temporal-frames", "0", timeout=600)
    raw = json.loads((out / "report.json").read_text())
    for i, p in enumerate(one_render_models):
        m = raw["methods"][f"model_{i}_{p.stem}"]
        s = m["summary"]
        assert all(_finite(s[k]) for k in ("psnr", "ssim", "flip")), (p.stem, s)
        t = s["time"]
        # one render gives every group: no G-buffer, the whole frame is that render + the prediction
        assert t["gbuffer_s"] == 0 and t["rest_s"] > 0, (p.stem, t)
        assert t["whole_s"] == pytest.approx(t["rest_s"] + t["predict_s"]), (p.stem, t)
