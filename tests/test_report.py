"""The speed-against-error report (issue 6): metric functions against known values, the equal-quality
interpolation, and a tiny end-to-end run on real Blender (2 random rooms at 64x36, baked through
`bake --scenes`, a short spp ladder, random-init tiny models), on the command line and from the Report button."""
import json
import math

import numpy as np
import pytest

from ssgi.model.learn import checkpoint, network
from ssgi.model import metrics
from ssgi.model.evaluate import analysis

from .conftest import run_cli, run_py

# ------------------------------------------------------------------------------------------ metrics


def test_psnr_of_a_known_mse_pooled_over_geometry_and_scenes():
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.2, 0.8, (10, 12, 3)).astype(np.float32)
    mask = np.zeros((10, 12), bool)
    mask[:, :6] = True
    pred = ref + np.float32(0.1)  # MSE 0.01 on the scored pixels -> 20 dB
    pred[~mask] += 0.3  # outside the geometry: not scored
    a = metrics.score(pred, ref, mask)
    assert a["psnr"] == pytest.approx(20.0, abs=1e-4) and a["pixels"] == 60 * 3
    b = metrics.score(ref + np.float32(0.2), ref, mask)  # MSE 0.04 -> 13.98 dB
    assert b["psnr"] == pytest.approx(10 * math.log10(1 / 0.04), abs=1e-4)
    # tonemapped PSNR: errors measured after x / (1 + x)
    assert a["tm_psnr"] == pytest.approx(metrics.tm_psnr(pred[mask], ref[mask]), abs=1e-9) and a["tm_psnr"] > a["psnr"]
    s = analysis.summarize_method({"per_scene": {"A": dict(a, time={"whole_s": 1.0, "own_s": 0.5}),
                                            "B": dict(b, time={"whole_s": 3.0, "own_s": 1.5})}})
    assert s["psnr"] == pytest.approx(10 * math.log10(1 / 0.025), abs=1e-4)  # MSE pooled, not PSNR averaged
    assert s["worst_scene"] == "B" and s["whole_s"] == 2.0 and s["own_s"] == 1.0


def test_ssim_and_flip_of_identical_images():
    rng = np.random.default_rng(1)
    img = rng.uniform(0, 3, (24, 40, 3)).astype(np.float32)
    m = metrics.score(img, img)
    assert m["ssim"] == pytest.approx(1.0) and m["flip"] == 0.0 and m["psnr"] == math.inf


def _lab(rgb):
    """CIELAB of linear sRGB (D65 white = XYZ of RGB 1,1,1)."""
    M = np.array([[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]])
    xyz = M @ np.asarray(rgb, float) / (M @ np.ones(3))
    d = 6 / 29
    f = np.where(xyz > d ** 3, np.cbrt(xyz), xyz / (3 * d * d) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _hyab_hunt(c1, c2):
    a, b = _lab(c1), _lab(c2)
    a[1:] *= 0.01 * a[0]  # Hunt adjustment
    b[1:] *= 0.01 * b[0]
    return abs(a[0] - b[0]) + math.hypot(a[1] - b[1], a[2] - b[2])


def test_flip_of_black_against_white_matches_the_papers_formula():
    """flip-evaluator's own example images (images/reference.png, test.png: mean 0.159691) ship in neither its
    wheel nor its sdist, so the known value comes from FLIP's colour pipeline (Andersson et al. 2020): two flat
    images have no feature error, so FLIP = the colour error: HyAB distance of Hunt-adjusted L*a*b*, to the power
    0.7, mapped by c_max (green against blue), p_c = 0.4, p_t = 0.95."""
    import flip_evaluator

    cmax = _hyab_hunt([0, 1, 0], [0, 0, 1]) ** 0.7
    e = _hyab_hunt([0, 0, 0], [1, 1, 1]) ** 0.7
    pc, pt = 0.4, 0.95
    want = pt / (pc * cmax) * e if e < pc * cmax else pt + (e - pc * cmax) / (cmax - pc * cmax) * (1 - pt)
    assert want == pytest.approx(0.9674, abs=5e-4)
    black, white = np.zeros((16, 16, 3), np.float32), np.ones((16, 16, 3), np.float32)
    _, mean, _ = flip_evaluator.evaluate(black, white, "LDR", inputsRGB=False, applyMagma=False)
    assert mean == pytest.approx(want, abs=2e-4)
    # metrics.flip scores a reference with no light by LDR-FLIP: the same number
    assert metrics.flip(white, black) == pytest.approx(want, abs=2e-4)
    # HDR-FLIP grows with the error
    rng = np.random.default_rng(2)
    ref = rng.uniform(0, 2, (32, 32, 3)).astype(np.float32)
    assert 0 < metrics.flip(ref * 1.1, ref) < metrics.flip(ref * 1.5, ref)


def test_temporal_change_is_the_mean_step_of_the_tonemapped_error():
    refs = [np.zeros((4, 4, 3), np.float32)] * 3
    preds = [np.full((4, 4, 3), v, np.float32) for v in (1.0, 3.0, 1.0)]  # tonemapped errors 0.5, 0.75, 0.5
    t = analysis.temporal_change(preds, refs)
    assert t["per_step"] == pytest.approx([0.25, 0.25]) and t["change"] == pytest.approx(0.25)
    assert t["mean_abs_error"] == pytest.approx((0.5 + 0.75 + 0.5) / 3)


# ------------------------------------------------------------------------------------------ equal quality


def test_equal_quality_interpolates_log_time_on_the_ladder():
    ladder = [(1.0, 30.0), (2.0, 34.0), (3.0, 33.0), (8.0, 38.0)]  # (3 s, 33 dB) is off the upper envelope
    e = analysis.equal_quality(ladder, 32.0, 0.5)
    assert e["bound"] == "=" and e["time_s"] == pytest.approx(math.sqrt(2.0)) and e["winner"] == "method"
    assert e["speedup"] == pytest.approx(2 * math.sqrt(2.0))
    e = analysis.equal_quality(ladder, 36.0, 10.0)  # halfway (in dB) from 2 s to 8 s -> 4 s; 10 s is slower
    assert e["time_s"] == pytest.approx(4.0) and e["speedup"] == pytest.approx(0.4) and e["winner"] == "cycles_oidn"
    e = analysis.equal_quality(ladder, 20.0, 2.0)  # below the cheapest rung, and slower than it: Cycles wins
    assert (e["bound"], e["time_s"], e["winner"]) == ("<=", 1.0, "cycles_oidn")
    e = analysis.equal_quality(ladder, 20.0, 0.1)  # below the ladder but cheaper than it: no verdict
    assert (e["bound"], e["winner"]) == ("<=", "undecided")
    e = analysis.equal_quality(ladder, 40.0, 2.0)  # above the best rung and faster than it: at least 4x
    assert (e["bound"], e["speedup"], e["winner"]) == (">=", 4.0, "method")


def test_pareto_front_and_closest_rung():
    pts = [("a", 1.0, 10.0), ("b", 2.0, 12.0), ("c", 2.0, 11.0), ("d", 0.5, 5.0), ("e", 3.0, 12.0)]
    assert sorted(analysis.pareto_front(pts)) == ["a", "b", "d"]
    assert analysis.closest_rung([(1, 0.1), (2, 0.3), (4, 1.2)], 0.5)[0] == 2  # log scale: 0.5 is nearer 0.3 than 1.2


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
    for v in ("unet_s", "lean", "unet", "linear"):
        torch.manual_seed(0)
        net = network.build(network.arch_for(v)).eval()
        checkpoint.save(d / f"{v}.pt", checkpoint.make(net, "linear" if v == "linear" else "network", command="test"))
        out.append(d / f"{v}.pt")
    return out


@pytest.fixture(scope="module")
def e2e(tmp_path_factory, tiny_models):
    d = tmp_path_factory.mktemp("report")
    blends = [d / "room3.blend", d / "room4.blend"]
    run_py(_ROOMS, *map(str, blends), timeout=120)
    out = d / "out"
    p = run_cli("report", "--scenes", *map(str, blends), "--models", *map(str, tiny_models), "--out", str(out),
                "--size", "64x36", "--ref-samples", "16", *TINY, "--sizes", "64x36,128x72", "--temporal-frames", "3",
                "--json", timeout=600)
    return dict(out=out, summary=json.loads(p.stdout), raw=json.loads((out / "report.json").read_text()),
                stderr=p.stderr, models=tiny_models)


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
        if k.startswith("model_"):  # learned: G-buffer + prediction; own cost = the prediction alone
            t = raw["methods"][k]["summary"]["time"]
            assert t["whole_s"] == pytest.approx(t["gbuffer_s"] + t["predict_s"]) and t["own_s"] == t["predict_s"]
            assert _finite(raw["methods"][k]["equal_quality"]["whole"]["speedup"])
    # the physics a wrong program gets wrong: more samples, less error; OIDN beats raw at 1 spp
    cyc = {n: raw["methods"][f"cycles_{n}"]["summary"]["psnr"] for n in (1, 2, 4)}
    assert cyc[1] < cyc[2] < cyc[4]
    assert raw["methods"]["cycles_oidn_1"]["summary"]["psnr"] > cyc[1]
    # the scenes reopened here are the ones the baker rendered
    assert all(v == "inf" or v > 40 for v in raw["gbuffer_agreement_db"].values())
    # params and FLOPs for the learned methods, in size order
    params = [raw["methods"][f"model_{i}_{v}"]["params"] for i, v in enumerate(("unet_s", "lean", "unet"))]
    assert params[2] > params[0] > params[1] > 0 and raw["methods"]["model_3_linear"]["params"] == 42
    # scaling and temporal numbers
    sc = raw["scaling"]
    assert sc["sizes"] == ["64x36", "128x72"] and all(
        len(rows) == 2 and all(_finite(r["ms"]) and r["ms"] > 0 for r in rows) for rows in sc["models"].values())
    tp = raw["temporal"]
    assert tp["frames"] == 3 and tp["oidn_spp"] in (1, 2, 4)
    assert all(_finite(r["change"]) and len(r["per_step"]) == 2 for r in tp["methods"].values())
    assert e2e["summary"]["ok"] and e2e["summary"]["default_model"] == "model_0_unet_s"


def test_report_md_has_the_table_verdicts_and_settings(e2e):
    md = (e2e["out"] / "report.md").read_text()
    for s in ("| EEVEE direct light only |", "| Cycles 4 spp + OIDN |", "SSGI unet_s", "linear regression",
              "## Where the learned methods stand against Cycles + OIDN", "## Scaling", "## Temporal stability",
              "## Settings", "## Machine and versions", "software GL", "cli.py report --scenes"):
        assert s in md, s
    table = md.split("## Methods")[1].split("## Where")[0]
    assert "n/a" not in table and "nan" not in table
    v = e2e["raw"]["verdicts"]["model_0_unet_s"][0]
    assert v.split(":")[0] in ("wins", "loses", "undecided")


def test_dataset_split_follows_the_models_checkpoint(e2e):
    """The default evaluation scenes are the validation scenes a model records for this very dataset."""
    from ssgi.model.dataset import folder
    from ssgi.ssgi_addon.pipeline import report as rr
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
    assert len([k for k in raw["methods"] if k.startswith("model_")]) == 4
    assert any(l.startswith("Written: ") and l.endswith("report.md") for l in r["after"]["labels"])
    assert ["ssgi.report", True] in r["after"]["operators"]
