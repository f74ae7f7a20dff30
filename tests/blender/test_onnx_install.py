"""Rendering without torch: the built zip, installed into a fresh Blender user folder with torch
hidden (a meta-path blocker: ``import torch`` fails in that process) and the venv's own onnxruntime hidden (only
the wheel the zip bundles can be imported), renders a tiny scene through the SSGI node with the shipped model's
ONNX export; the frame equals what torch predicts from that render's own passes. And the command line without
torch: ``predict`` runs the export, a corrupt .onnx is one clear line, ``train`` says it needs torch."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..conftest import ROOT, run_cli, run_py
from .test_node import SCENE, read_rgba

SHIPPED = ROOT / "models" / "ssgi_default.pt"

_INSTALL_AND_RENDER = r'''
import importlib, importlib.machinery, json, site, sys
VENV_SITE = set(site.getsitepackages())
class HideVenvOnnxruntime:
    def find_spec(self, name, path=None, target=None):
        if name == "onnxruntime":
            spec = importlib.machinery.PathFinder.find_spec(name, [p for p in sys.path if p not in VENV_SITE])
            if spec is None:
                raise ImportError("onnxruntime not found outside the venv")
            return spec
        return None
sys.meta_path.insert(0, HideVenvOnnxruntime())
rep = {}
try:
    import torch
    rep["torch"] = torch.__file__
except ImportError as e:
    rep["torch"], rep["torch_error"] = None, str(e)
''' + SCENE + r'''
zip_path, out_dir = sys.argv[1], sys.argv[2]
sc = build_room(out_dir + "/f_####")  # factory settings first: they would unload the extension
rep["install"] = sorted(bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                                 enable_on_install=True))
PKG = "bl_ext.user_default.ssgi"
rep["setup"] = sorted(bpy.ops.ssgi.setup())  # no model given: the shipped one, inside the installed extension
R = importlib.import_module(PKG + ".ssgi_addon.pipeline.render")
s = R.RenderSession(sc, [2], save_passes=out_dir + "/passes")
rep["summary"] = s.run()
import onnxruntime
rep["onnxruntime_file"] = onnxruntime.__file__
rep["predictor_file"] = str(s.predictor.path)
rep["clip_end"] = sc.camera.data.clip_end
rep["user_resources"] = bpy.utils.resource_path("USER")
print("REPORT" + json.dumps(rep, default=str))
'''


def test_zip_installed_without_torch_renders_through_the_node_with_the_bundled_onnxruntime(built_zip, no_torch_env,
                                                                                           tmp_path):
    p = run_py(_INSTALL_AND_RENDER, str(built_zip), str(tmp_path), env=no_torch_env, timeout=600)
    rep = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])
    assert rep["torch"] is None and "hidden by the SSGI test" in rep["torch_error"], rep
    assert rep["install"] == ["FINISHED"] and rep["setup"] == ["FINISHED"], rep
    ort_file = rep["onnxruntime_file"]
    assert ort_file.startswith(rep["user_resources"]) and "/extensions/.local/" in ort_file, ort_file
    assert rep["summary"]["runtime"] == "onnx", rep["summary"]
    assert rep["predictor_file"].endswith("/ssgi/models/ssgi_default.onnx")
    assert rep["predictor_file"].startswith(rep["user_resources"])  # the copy the zip installed
    frame = read_rgba(rep["summary"]["files"][0])
    # what torch (here, in the test process) predicts from that very render's passes, composed as the node does
    from ssgi.model.dataset import exrio
    from ssgi.model.infer import export, predictor
    pred = predictor.load_predictor(SHIPPED, runtime="torch", precision="fp32", device="cpu")
    assert pred.target == "ref_diffuse"
    g = exrio.read_sample(tmp_path / "passes" / "000002.exr", pred.required + ("depth", "normal", "rest"), strict=False)
    expected = np.maximum(pred.predict(g) + g["rest"][..., :3], 0)
    assert frame.shape == (36, 64, 4) and np.isfinite(frame).all()
    assert export.bound_ratio(pred, g, expected, frame[..., :3], added=g["rest"]) <= 1.0
    geo = g["depth"][..., 0] < 0.999 * rep["clip_end"]
    assert geo.mean() > 0.3 and np.abs(frame[..., :3] - g["rest"][..., :3])[geo].mean() > 1e-3  # a prediction was added
    magenta = np.array([1.0, 0.0, 1.0])
    assert np.abs(frame[..., :3] - magenta).max() > 0.1  # not the placeholder


def test_cli_without_torch_predicts_with_the_export_and_says_what_needs_torch(tmp_path, no_torch_env):
    from ssgi.model.dataset import exrio
    from ssgi.model.infer import export, predictor
    torch_pred = predictor.load_predictor(SHIPPED, runtime="torch", precision="fp32", device="cpu")
    sample = tmp_path / "s.exr"
    g = export.hdr_groups(40, 24)
    exrio.write_sample(sample, {k: g[k] for k in torch_pred.required}, half=False)
    out = tmp_path / "o.exr"
    p = run_cli("predict", "--model", str(SHIPPED), "--input", str(sample), "--out", str(out), "--json",
                env=no_torch_env)
    d = json.loads(p.stdout)
    assert d["ok"] and d["runtime"] == "onnx" and d["device"] == "cpu", d
    assert d["model_file"].endswith("ssgi_default.onnx")
    planes = exrio.read_exr(out)[0]
    got = np.stack([planes[c] for c in "RGB"], -1)
    ref = torch_pred.predict(exrio.read_sample(sample, torch_pred.required))
    assert export.bound_ratio(torch_pred, exrio.read_sample(sample, torch_pred.required), ref, got) <= 1.0
    # a checkpoint without an export cannot run without torch: one line that says what to do
    lone = tmp_path / "lone.pt"
    lone.write_bytes(SHIPPED.read_bytes())
    p = run_cli("predict", "--model", str(lone), "--input", str(sample), "--out", str(out), env=no_torch_env, check=False)
    assert p.returncode == 2 and "lone.pt: this Python has no PyTorch" in p.stderr and "cli.py export" in p.stderr
    assert "Traceback" not in p.stderr
    # a corrupt .onnx: exit 2, one line naming the file, no traceback
    cut = tmp_path / "cut.onnx"
    cut.write_bytes(SHIPPED.with_suffix(".onnx").read_bytes()[:5000])
    p = run_cli("predict", "--model", str(cut), "--input", str(sample), "--out", str(out), env=no_torch_env, check=False)
    assert p.returncode == 2 and "cut.onnx: not a readable ONNX model" in p.stderr and "Traceback" not in p.stderr
    info = json.loads(run_cli("info", "--json", env=no_torch_env).stdout)
    assert info["torch"] is None and info["onnxruntime"].startswith("1.30.0 (") and "CPU" in info["onnxruntime"]
    # training and export still need torch, and say so
    p = run_cli("export", "--model", str(SHIPPED), "--out", str(tmp_path / "x.onnx"), env=no_torch_env, check=False)
    assert p.returncode == 2 and "needs torch" in p.stderr
    p = run_cli("train", "--data", str(tmp_path), "--out", str(tmp_path / "m.pt"), env=no_torch_env, check=False)
    assert p.returncode != 0 and "torch" in p.stderr.lower()


def test_export_button_writes_the_export_beside_the_scene_model_and_reports_a_bad_one(tmp_path):
    model = tmp_path / "m.pt"
    model.write_bytes(SHIPPED.read_bytes())
    p = run_py(f'''
import bpy, ssgi
ssgi.register()
bpy.context.scene.ssgi.model_path = {str(model)!r}
print("FIRST", sorted(bpy.ops.ssgi.export_onnx()))
bpy.context.scene.ssgi.model_path = {str(tmp_path / "nope.pt")!r}
try:
    bpy.ops.ssgi.export_onnx()
except RuntimeError as e:
    print("SECOND", str(e).strip())
''', timeout=300)
    assert "FIRST ['FINISHED']" in p.stdout
    assert f"SECOND Error: {tmp_path / 'nope.pt'}: no such model file" in p.stdout
    from ssgi.model.infer import onnx as ort_backend
    assert ort_backend.export_of(model) == model.with_suffix(".onnx")
