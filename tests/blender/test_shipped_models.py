"""The user's paths with the models a user gets: each shipped model (models/ssgi_default.pt, models/ssgi_one_render.pt)
at its default settings, through `cli.py render` (working resolution `auto` at 960 px wide, temporal mode on for a
short animation), the Set up SSGI and Render SSGI Image / Animation operators, `cli.py export` and `cli.py predict`,
and `cli.py fit` with no --init (the shipped starting model). The scene is Blender's own startup file (the default
cube, light, camera and grey world; EEVEE with ray tracing off, as a new file has it), with a camera move over two
frames and the scene's render samples at 1 to keep the renders short. (The demo with both models: test_demo.py; the
report: test_report.py's end-to-end run lists both.)"""
from __future__ import annotations

import json

import numpy as np
import pytest

from ..conftest import ROOT, run_cli, run_py
from .test_node import read_rgba

MODELS = {"default": ROOT / "models" / "ssgi_default.pt", "one_render": ROOT / "models" / "ssgi_one_render.pt"}
# the working resolution `auto` at 960 px wide: 1/4 per axis for a one-render model, else a working image 480 px wide
AUTO_FACTOR_AT_960 = {"default": 2, "one_render": 4}

_STARTUP = r'''
import sys, bpy
bpy.ops.wm.read_factory_settings(use_empty=False)
sc = bpy.context.scene
w, h = int(sys.argv[2]), int(sys.argv[3])
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = w, h, 100
sc.eevee.taa_render_samples = 1
sc.frame_start, sc.frame_end = 1, 2
cam = sc.camera
cam.keyframe_insert("location", frame=1)
cam.location.x += 0.15
cam.keyframe_insert("location", frame=2)
assert not sc.eevee.use_raytracing and sc.world is not None
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
'''

# EEVEE's own render of the file (its settings, no SSGI), one frame, as an EXR
_OWN = r'''
import sys, bpy
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
sc = bpy.context.scene
sc.frame_set(int(sys.argv[3]))
sc.render.image_settings.file_format = "OPEN_EXR"
sc.render.filepath = sys.argv[2]
bpy.ops.render.render(write_still=True)
'''


def _startup(path, w, h):
    run_py(_STARTUP, str(path), str(w), str(h), timeout=120)
    return path


@pytest.fixture(scope="module")
def startup_960(tmp_path_factory):
    d = tmp_path_factory.mktemp("startup960")
    blend = _startup(d / "startup.blend", 960, 540)
    run_py(_OWN, str(blend), str(d / "own.exr"), "2", timeout=300)
    return dict(blend=blend, own=read_rgba(d / "own.exr"), dir=d)


def _check_frame(frame: np.ndarray, own: np.ndarray, what: str) -> None:
    """An SSGI frame of the startup scene: finite, not the magenta placeholder, and no surface that EEVEE's own render
    shows is black (the cube's faces and the grey world keep at least a fifth of EEVEE's light: the models add light
    to EEVEE's image or predict the diffuse part under it; a black or placeholder frame fails)."""
    rgb = frame[..., :3]
    assert rgb.shape == own[..., :3].shape and np.isfinite(rgb).all(), what
    assert np.abs(rgb - np.array([1.0, 0.0, 1.0])).max(axis=-1).min() > 0.05, f"{what}: magenta placeholder pixels"
    lum, own_lum = rgb.mean(-1), own[..., :3].mean(-1)
    seen = own_lum > 0.02
    assert seen.mean() > 0.9, "the startup scene is lit and shows its world everywhere"
    assert (lum[seen] >= 0.2 * own_lum[seen]).mean() > 0.999, f"{what}: pixels black where EEVEE shows light"
    assert abs(float(np.log(lum[seen].mean() / own_lum[seen].mean()))) < np.log(3), what


@pytest.mark.parametrize("which", list(MODELS))
def test_cli_render_at_960_with_auto_working_res_and_temporal_on(startup_960, which, tmp_path):
    d = startup_960
    model = () if which == "default" else ("--model", str(MODELS[which]))  # no --model: the shipped default
    p = run_cli("render", "--blend", str(d["blend"]), "--setup", *model, "--frames", "1-2", "--temporal", "on",
                "--out", str(tmp_path / "f_####.exr"), "--json", timeout=900)
    s = json.loads(p.stdout)
    assert s["ok"] and s["model"].endswith(MODELS[which].name) and s["temporal"] is True, s
    assert s["frames"] == [1, 2] and len(s["files"]) == 2
    for r in s["per_frame"]:
        assert r["working_factor"] == AUTO_FACTOR_AT_960[which], r
    assert s["per_frame"][1]["history_frames"], s["per_frame"][1]  # frame 2 blended with frame 1's prediction
    _check_frame(read_rgba(s["files"][1]), d["own"], f"{which} frame 2")


_OPERATORS = r'''
import json, sys, bpy, ssgi
ssgi.register()
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
model, out = sys.argv[2], sys.argv[3]
r = {"setup": sorted(bpy.ops.ssgi.setup(model=model) if model else bpy.ops.ssgi.setup())}
sc = bpy.context.scene
sc.render.image_settings.file_format = "OPEN_EXR"  # the artist's output format
sc.frame_set(2)
r["image"] = sorted(bpy.ops.ssgi.render(write_still=True, filepath=out + "image_####"))
r["animation"] = sorted(bpy.ops.ssgi.render(animation=True, write_still=True, filepath=out + "anim_####"))
print("REPORT" + json.dumps(r))
'''


@pytest.mark.parametrize("which", list(MODELS))
def test_set_up_and_render_image_and_animation_operators(which, tmp_path):
    """The artist's path in Blender: Set up SSGI (the shipped default when no model is named), Render SSGI Image
    (the current frame) and Render SSGI Animation (the scene's range), each writing where asked."""
    blend = _startup(tmp_path / "startup.blend", 192, 108)
    run_py(_OWN, str(blend), str(tmp_path / "own.exr"), "2", timeout=300)
    own = read_rgba(tmp_path / "own.exr")
    model = "" if which == "default" else str(MODELS[which])
    p = run_py(_OPERATORS, str(blend), model, str(tmp_path) + "/", timeout=900)
    r = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])
    assert r == {"setup": ["FINISHED"], "image": ["FINISHED"], "animation": ["FINISHED"]}, r
    assert sorted(f.name for f in tmp_path.glob("*_0*.exr")) == ["anim_0001.exr", "anim_0002.exr", "image_0002.exr"]
    image, anim2 = read_rgba(tmp_path / "image_0002.exr"), read_rgba(tmp_path / "anim_0002.exr")
    _check_frame(image, own, f"{which} Render SSGI Image")
    _check_frame(anim2, own, f"{which} Render SSGI Animation")


@pytest.mark.parametrize("which", list(MODELS))
def test_cli_export_and_predict_with_the_shipped_model(which, tmp_path):
    """`cli.py export` writes the shipped checkpoint's ONNX file on this CPU (its parity check passes) and it equals
    the shipped export's graph; `cli.py predict` runs the model on an EXR of its inputs."""
    import onnx
    from onnx import numpy_helper

    from ssgi.model.dataset import exrio
    from ssgi.model.infer import export, predictor
    pt = MODELS[which]
    out = tmp_path / "m.onnx"
    s = json.loads(run_cli("export", "--model", str(pt), "--out", str(out), "--json", timeout=600).stdout)
    assert s["ok"] and out.is_file() and s["parity"]["max_ratio"] <= 1.0, s
    a, b = onnx.load(str(out)), onnx.load(str(pt.with_suffix(".onnx")))
    assert [n.op_type for n in a.graph.node] == [n.op_type for n in b.graph.node]
    assert all(np.array_equal(numpy_helper.to_array(x), numpy_helper.to_array(y))
               for x, y in zip(a.graph.initializer, b.graph.initializer))

    torch_pred = predictor.load_predictor(pt, runtime="torch", precision="fp32", device="cpu")
    g = export.hdr_groups(48, 32, seed=3)
    sample = tmp_path / "s.exr"
    exrio.write_sample(sample, {k: g[k] for k in torch_pred.required}, half=False)
    res = tmp_path / "o.exr"
    d = json.loads(run_cli("predict", "--model", str(pt), "--input", str(sample), "--out", str(res), "--json").stdout)
    assert d["ok"] and d["runtime"] == "onnx", d  # the shipped export beside the checkpoint runs it
    planes = exrio.read_exr(res)[0]
    got = np.stack([planes[c] for c in "RGB"], -1)
    groups = exrio.read_sample(sample, torch_pred.required)
    assert export.bound_ratio(torch_pred, groups, torch_pred.predict(groups), got) <= 1.0


def test_cli_fit_with_no_init_starts_from_the_shipped_model_and_renders_with_the_fit(tmp_path):
    """`cli.py fit` at its defaults fine-tunes the shipped default model (no --init), on a few views of the startup
    scene at a tiny size, and the fitted model renders the scene."""
    blend = _startup(tmp_path / "startup.blend", 64, 36)
    model = tmp_path / "fit.pt"
    p = run_cli("fit", "--blend", str(blend), "--out", str(model), "--views", "4", "--minutes", "0.4", "--size",
                "64x36", "--ref-samples", "4", "--min-run-seconds", "1", "--json", timeout=900)
    s = json.loads(p.stdout)
    assert s["ok"] and model.is_file(), s
    assert str(s["init"]).endswith("ssgi_default.pt"), s["init"]
    r = json.loads(run_cli("render", "--blend", str(blend), "--setup", "--model", str(model), "--frames", "2",
                           "--out", str(tmp_path / "fit_####.exr"), "--json", timeout=300).stdout)
    run_py(_OWN, str(blend), str(tmp_path / "own.exr"), "2", timeout=300)
    _check_frame(read_rgba(r["files"][0]), read_rgba(tmp_path / "own.exr"), "fitted model")
