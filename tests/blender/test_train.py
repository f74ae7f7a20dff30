"""The train/predict CLI and the Train operator, panel and status bar in Blender. The bpy-free trainer,
dataset and baseline tests are tests/unit/test_train.py."""
import json
import math

import pytest

from ssgi.model.dataset import exrio, synthetic
from ssgi.model.learn import checkpoint

from ..conftest import run_cli
from ..unit.test_train import dataset_dir  # noqa: F401  (a fixture)


# ---------------------------------------------------------------- CLI

def test_cli_train_predict_and_user_errors(tmp_path, dataset_dir):
    m = tmp_path / "m.pt"
    p = run_cli("train", "--data", str(dataset_dir), "--out", str(m), "--variant", "unet_s", "--inputs", "albedo,normal,depth,direct,lit", "--epochs", "1",
                "--crop", "16", "--batch", "4", "--quiet", "--json")
    d = json.loads(p.stdout)
    assert d["ok"] and d["epochs"] == 1 and math.isfinite(d["best"]["val_psnr"])
    assert "cli.py train" in checkpoint.load(m)["command"]
    out, png = tmp_path / "o.exr", tmp_path / "o.png"
    p = run_cli("predict", "--model", str(m), "--input", str(dataset_dir / "000003.exr"), "--out", str(out),
                "--png", str(png), "--json")
    d = json.loads(p.stdout)
    planes, _ = exrio.read_exr(out)
    assert sorted(planes) == ["B", "G", "R"] and planes["R"].shape == (24, 40)
    assert png.stat().st_size > 100 and math.isfinite(d["psnr"])
    # user errors: exit 2, the file named, no traceback, nothing written
    bad = tmp_path / "notes.txt"
    bad.write_text("not a model")
    p = run_cli("predict", "--model", str(bad), "--input", str(dataset_dir / "000003.exr"), "--out",
                str(tmp_path / "x.exr"), check=False)
    assert p.returncode == 2 and "notes.txt: not an SSGI model checkpoint" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "x.exr").exists()
    p = run_cli("train", "--data", str(tmp_path / "nope"), "--out", str(m), "--epochs", "1", check=False)
    assert p.returncode == 2 and "nope: dataset folder does not exist" in p.stderr


# ---------------------------------------------------------------- Blender: Train operator, panel, status bar

@pytest.fixture(scope="module")
def shipped_dataset_dir(tmp_path_factory):
    """A synthetic dataset holding every group the shipped default model (the Train operator's network) reads."""
    return synthetic.make_dataset(tmp_path_factory.mktemp("syn-shipped"), scenes=5, per_scene=2, w=40, h=24, seed=7,
                                  shipped=True)


_BLENDER_TRAIN = r'''
import json, sys, time
import bpy
import ssgi
from tests import ui_recorder
bpy.ops.wm.read_factory_settings(use_empty=True)
ssgi.register()
from ssgi.ssgi_addon.runtime import jobs
from ssgi.panels.train_panel import SSGI_PT_train
sc = bpy.context.scene
sc.ssgi.dataset_dir, sc.ssgi.train_out, sc.ssgi.train_variant = sys.argv[1], sys.argv[2], "unet_s"
sc.ssgi.train_minutes = float(sys.argv[3])
rep = {}
sc.ssgi.dataset_dir = sys.argv[1] + "-missing"
try:
    bpy.ops.ssgi.train()
except RuntimeError as e:  # the operator's ERROR report becomes a RuntimeError in the bpy module
    rep["missing_error"] = str(e)
sc.ssgi.dataset_dir = sys.argv[1]
rep["op"] = sorted(bpy.ops.ssgi.train())
job = jobs.get("train")
rep["poll_while_running"] = bpy.ops.ssgi.train.poll()
pumps, drawn, t0 = 0, None, time.time()
while job.pump():
    pumps += 1
    if drawn is None and job.state.get("epoch", 0) >= 1:
        rec = ui_recorder.draw(SSGI_PT_train)
        drawn = {"labels": rec.labels(), "operators": rec.operators(), "texts": [e["kw"].get("text") for e in rec.log if e["fn"] == "progress"]}
        import types
        from ssgi.panels import status_bar
        bar = ui_recorder.draw(types.SimpleNamespace(draw=status_bar.draw_status))
        drawn["status_bar"] = [e["kw"].get("text") for e in bar.log if e["fn"] == "progress"]
        if sys.argv[4] == "cancel":
            bpy.ops.ssgi.cancel_job(job="train")
            rep["cancel_asked_at_step"] = job.state["step"]
    time.sleep(0.02)
rep["pump_rate"] = pumps / max(time.time() - t0, 1e-6)
rep["state"] = {k: v for k, v in job.state.items() if k != "log"}
rep["result"] = job.result
rep["drawn"] = drawn
rep["model_path"] = sc.ssgi.model_path
rec = ui_recorder.draw(SSGI_PT_train)
rep["after"] = {"labels": rec.labels(), "operators": rec.operators()}
print("REPORT" + json.dumps(rep, default=str))
'''


def _report(p) -> dict:
    return json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])


def test_blender_train_operator_runs_in_background_and_panel_shows_progress(tmp_path, shipped_dataset_dir):
    from ..conftest import run_py
    out = tmp_path / "ui.pt"
    rep = _report(run_py(_BLENDER_TRAIN, str(shipped_dataset_dir), str(out), "0.1", "run", timeout=300))
    assert "dataset folder does not exist" in rep["missing_error"]
    assert rep["op"] == ["FINISHED"] and rep["poll_while_running"] is False
    assert rep["state"]["status"] == "done" and rep["result"]["status"] == "done"
    assert rep["pump_rate"] > 5  # the main thread kept running while the worker trained
    assert rep["drawn"]["operators"] == [["ssgi.cancel_job", True]]
    assert rep["drawn"]["texts"] and "Epoch" in rep["drawn"]["texts"][0] and "val" in rep["drawn"]["texts"][0]
    # the one status-bar drawer shows the running training, with the panel's line
    assert rep["drawn"]["status_bar"] == ["SSGI training: " + rep["drawn"]["texts"][0]]
    assert rep["model_path"] == str(out) and checkpoint.load(out)["arch"]["variant"] == "unet_s"
    assert ["ssgi.train", True] in rep["after"]["operators"]
    assert any(l.startswith("Done after epoch") and "dB" in l for l in rep["after"]["labels"])


def test_blender_train_cancel_keeps_last_checkpoint(tmp_path, shipped_dataset_dir):
    from ..conftest import run_py
    out = tmp_path / "ui.pt"
    rep = _report(run_py(_BLENDER_TRAIN, str(shipped_dataset_dir), str(out), "5", "cancel", timeout=300))
    assert rep["state"]["status"] == "cancelled" and rep["result"] is None
    last = checkpoint.load(checkpoint.last_path(out))
    assert last["train_state"]["epoch"] >= 1
    assert rep["state"]["step"] <= rep["cancel_asked_at_step"] + 1  # stopped within one batch
    assert rep["model_path"] == ""  # a cancelled run does not switch the scene's model
