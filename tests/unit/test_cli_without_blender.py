"""A training or inference node without Blender: `cli.py` lists its subcommands and runs train, export, predict,
merge, verify and info in a Python where bpy cannot be imported (this lane's subprocesses hide it: conftest.py);
a command that needs Blender answers with one line that says what to install, and exits 2."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from ..conftest import ROOT

DATASET = ROOT / "tests" / "fixtures" / "dataset"


def _cli(*args, check=True, timeout=600):
    p = subprocess.run([sys.executable, str(ROOT / "cli.py"), *args], capture_output=True, text=True, cwd=ROOT,
                       timeout=timeout)
    if check:
        assert p.returncode == 0, p.stderr[-3000:]
    return p


def test_bpy_is_hidden_here():
    p = subprocess.run([sys.executable, "-c", "import bpy"], capture_output=True, text=True)
    assert p.returncode != 0 and "ImportError" in p.stderr


def test_help_lists_every_subcommand_and_marks_those_that_need_blender():
    out = _cli("--help").stdout
    for name in ("info", "randomize", "bake", "verify", "merge", "preview", "demo", "train", "predict", "export",
                 "render", "setup", "fit", "report"):
        assert f"    {name}" in out, name
    assert out.count("needs Blender") >= 2  # randomize and bake import bpy to build their options


@pytest.mark.parametrize("argv", [("bake", "--out", "x", "--count", "1"), ("render", "--blend", "a.blend"),
                                  ("demo", "--out", "x"), ("randomize", "--seed", "1", "--out", "r.blend"),
                                  ("setup", "--blend", "a.blend", "--out", "b.blend", "--compiled")])
def test_a_blender_command_says_what_to_install_in_one_line(argv):
    p = _cli(*argv, "--json", check=False)
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    d = json.loads(p.stdout)
    assert d["ok"] is False and d["error"].startswith(f"{argv[0]} needs Blender"), d
    assert "pip install bpy==5.0.1" in d["error"] and "blender --background --python cli.py" in d["error"]
    assert "Traceback" not in p.stderr


def test_info_train_export_predict_merge_and_verify_run_without_blender(tmp_path):
    info = json.loads(_cli("info", "--json").stdout)
    assert info["blender"] is None and "bpy" in info["blender_error"] and info["torch"], info

    data = tmp_path / "data"
    shutil.copytree(DATASET, data)  # as two machines' shards of a bake would leave it: one manifest each
    whole = json.loads((data / "manifest.json").read_text())
    for i, name in enumerate(sorted(whole["samples"])):
        shard = dict(whole, samples={name: whole["samples"][name]}, settings=dict(whole["settings"], shard=[i, 2]))
        (data / f"manifest.shard-{i}-of-2.json").write_text(json.dumps(shard))
    (data / "manifest.json").unlink()
    m = json.loads(_cli("merge", str(data), "--json").stdout)
    assert m["ok"] and m["samples"] == 2 and len(m["shards"]) == 2, m
    v = json.loads(_cli("verify", str(data), "--json").stdout)
    assert v["ok"] and v["samples"] == 2 and v["problems"] == [], v

    model = tmp_path / "m.pt"
    t = json.loads(_cli("train", "--data", str(data), "--out", str(model), "--variant", "unet_s", "--inputs", "albedo,normal,depth,direct,lit", "--epochs", "1",
                        "--crop", "32", "--batch", "2", "--quiet", "--json").stdout)
    assert t["ok"] and model.is_file(), t
    e = json.loads(_cli("export", "--model", str(model), "--json").stdout)
    assert e["ok"] and model.with_suffix(".onnx").is_file() and e["parity"]["max_ratio"] <= 1.0, e

    out = tmp_path / "pred.exr"
    sample = sorted(data.glob("*.exr"))[0]
    p = json.loads(_cli("predict", "--model", str(model), "--input", str(sample), "--out", str(out), "--json").stdout)
    assert p["ok"] and p["runtime"] == "onnx", p  # the export beside the checkpoint
    from ssgi.model.dataset import exrio
    planes = exrio.read_exr(out)[0]
    rgb = np.stack([planes[c] for c in "RGB"], -1)
    assert rgb.ndim == 3 and np.isfinite(rgb).all() and rgb.max() > 0
