"""ONNX export and the onnxruntime runtime (bpy-free): parity with torch on HDR inputs, tiled and untiled, at
several sizes; the shipped export is the reproducible export of the shipped checkpoint; runtime choice; a
corrupt, foreign or older .onnx gets a clear one-line error. (The command line without torch and the installed
zip: tests/blender/test_onnx_install.py.)"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import onnx
import pytest
import torch

from ssgi.model import channels as ch
from ssgi.model.errors import UserError
from ssgi.model.infer import compose, export, onnx as ort_backend, predictor
from ssgi.model.learn import checkpoint, network

from ..conftest import ROOT

SHIPPED = ROOT / "models" / "ssgi_default.pt"
# the one-render model: one GI-off EEVEE render, the sky group
SHIPPED_ONE = ROOT / "models" / "ssgi_one_render.pt"
SIZES = ((1, 1, None), (7, 5, None), (64, 36, None), (203, 131, 96), (33, 301, 64))  # width, height, tile


def _checkpoint(path: Path, variant: str, seed: int = 0, inputs=ch.DEFAULT_INPUTS) -> Path:
    torch.manual_seed(seed)
    net = network.build(network.arch_for(variant, inputs)).eval()
    with torch.no_grad():  # a random net at init is nearly flat: larger weights make the parity test bite
        for p in net.parameters():
            p.mul_(1.5)
    checkpoint.save(path, checkpoint.make(net, "network", command="tests/unit/test_onnx.py"))
    return path


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d = tmp_path_factory.mktemp("onnx")
    out = {"shipped": SHIPPED, "shipped_one_render": SHIPPED_ONE}
    for v in ("fssgi", "unet", "linear"):
        out[v] = _checkpoint(d / f"{v}.pt", v)
        export.export(out[v], command="test")
    return out


@pytest.mark.parametrize("name", ["shipped", "shipped_one_render", "fssgi", "unet", "linear"])
def test_onnx_equals_torch_within_float32_rounding_on_hdr_inputs_tiled_and_untiled(models, name):
    pt = models[name]
    a = predictor.load_predictor(pt, runtime="torch", precision="fp32", device="cpu")
    b = predictor.load_predictor(pt, runtime="onnx")
    assert isinstance(b, ort_backend.OrtPredictor) and b.runtime == "onnx" and b.device == "cpu"
    assert (b.target, b.inputs, b.required) == (a.target, a.inputs, a.required)
    for w, h, tile in SIZES:
        g = export.hdr_groups(w, h, seed=w)
        assert max(float(g["direct"].max()), 1.0) > (1e3 if w * h > 100 else 0)  # HDR light, to 1e4
        def image(p, tile):  # a combined model's prediction is signed (image - EEVEE's): compare the images
            y = p.predict(g, tile=tile)
            return compose.compose(y, g, p.target) if p.target == ch.COMBINED_TARGET else y

        ya, yb = image(a, tile), image(b, tile)
        assert yb.shape == (h, w, 3) and yb.dtype == np.float32 and np.isfinite(yb).all()
        added = g["eevee_combined"] if a.target == ch.COMBINED_TARGET else None
        assert export.bound_ratio(a, g, ya, yb, tile, added) <= 1.0, (name, w, h, tile)
        assert float(ya.max()) > 0 or w * h < 100
        if tile:  # the tiles' kept cores equal the untiled result in onnxruntime as in torch (up to the rounding of
            # another summation order: a GEMM's blocking follows the image's width)
            assert export.bound_ratio(a, g, image(b, None), yb, tile, added) <= 1.0
    # the comparison bites: a different network is far off
    other = predictor.load_predictor(models["fssgi" if name != "fssgi" else "unet"], runtime="onnx")
    if other.inputs == b.inputs:
        assert export.rel_diff(other.predict(g), yb) > 1e-2


def _graph(path: Path) -> tuple[list, dict, dict]:
    """What an export holds that no CPU's kernels change: the nodes (op, inputs, outputs, attributes), the weights
    (bit for bit) and the metadata."""
    from onnx import numpy_helper
    m = onnx.load(str(path))
    nodes = [(n.op_type, list(n.input), list(n.output), sorted(str(a) for a in n.attribute)) for n in m.graph.node]
    weights = {t.name: numpy_helper.to_array(t) for t in m.graph.initializer}
    return nodes, weights, {p.key: p.value for p in m.metadata_props}


@pytest.mark.parametrize("pt", [SHIPPED, SHIPPED_ONE], ids=["default", "one_render"])
def test_shipped_onnx_is_the_reproducible_export_of_the_shipped_checkpoint(tmp_path, pt):
    shipped = pt.with_suffix(".onnx")
    assert ort_backend.export_of(pt) == shipped  # its source_sha256 is the shipped .pt's
    meta = {p.key: json.loads(p.value) for p in onnx.load(str(shipped)).metadata_props}
    ck = checkpoint.load(pt)
    for k in ("inputs", "channel_spec", "arch", "best", "history", "command", "dataset", "normalization"):
        assert meta[k] == json.loads(json.dumps(ck[k], default=str)), k
    again = tmp_path / "again.onnx"
    res = export.export(pt, again, command=meta["export_command"])  # what `cli.py export` runs, its check included
    nodes, weights, meta_again = _graph(again)
    nodes0, weights0, meta0 = _graph(shipped)
    assert nodes == nodes0, "the re-export's graph differs: run the export_command in its metadata"
    assert weights.keys() == weights0.keys() and all(np.array_equal(weights[k], weights0[k]) for k in weights)
    assert meta_again == meta0
    assert res["parity"]["max_ratio"] <= 1.0


@pytest.mark.parametrize("pt", [SHIPPED, SHIPPED_ONE], ids=["default", "one_render"])
def test_export_refuses_a_graph_with_one_weight_changed_by_one_percent(tmp_path, pt, monkeypatch):
    """The parity check bites: the torch side of the check gets the output convolution's first weight x 1.01
    (a change of the network, not of rounding) and the export is refused, its file removed."""
    class Changed(predictor.Predictor):
        def __init__(self, net, *a, **kw):
            import copy
            net = copy.deepcopy(net)
            last = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)][-1]
            with torch.no_grad():
                last.weight.view(-1)[0] *= 1.01
            super().__init__(net, *a, **kw)

    monkeypatch.setattr(predictor, "Predictor", Changed)
    out = tmp_path / "changed.onnx"
    with pytest.raises(UserError, match=r"changed\.onnx: the ONNX graph differs from the checkpoint by more than "
                                        r"float32 rounding explains .*not written"):
        export.export(pt, out, command="test")
    assert not out.exists()


def test_parity_tolerance_holds_across_torch_kernels_where_a_relative_one_fails():
    """Other summation orders (torch without oneDNN on one thread; channels-last memory) stay within the rounding
    bound for both shipped models, as another CPU's kernels must."""
    for pt in (SHIPPED, SHIPPED_ONE):
        a = predictor.load_predictor(pt, runtime="torch", precision="fp32", device="cpu")
        g = export.hdr_groups(96, 64, seed=5)
        added = g["eevee_combined"] if a.target == ch.COMBINED_TARGET else None
        ya = a.predict(g)
        threads = torch.get_num_threads()
        try:
            torch.backends.mkldnn.enabled = False
            torch.set_num_threads(1)
            yb = a.predict(g)
        finally:
            torch.backends.mkldnn.enabled = True
            torch.set_num_threads(threads)
        yc = predictor.load_predictor(pt, runtime="torch", precision="fp32-cl", device="cpu").predict(g)
        for y in (yb, yc):
            assert export.bound_ratio(a, g, ya, y, None, added) <= 1.0, pt.name


def test_auto_runtime_takes_the_matching_export_and_never_a_stale_one(models, tmp_path):
    assert predictor.load_predictor(models["unet"]).runtime == "onnx"
    stale = tmp_path / "m.pt"
    stale.write_bytes(models["unet"].read_bytes())
    (tmp_path / "m.onnx").write_bytes(Path(models["fssgi"]).with_suffix(".onnx").read_bytes())  # not m.pt's export
    assert ort_backend.export_of(stale) is None
    p = predictor.load_predictor(stale)
    assert p.runtime == "torch" and isinstance(p, predictor.Predictor)
    with pytest.raises(UserError, match=r"m\.pt: no ONNX export of this file beside it .*cli\.py export --model"):
        predictor.load_predictor(stale, runtime="onnx")
    with pytest.raises(UserError, match="not torch"):
        predictor.load_predictor(tmp_path / "m.onnx", runtime="torch")
    with pytest.raises(UserError, match="runtime must be one of auto, torch, onnx"):
        predictor.load_predictor(stale, runtime="tensorflow")


def test_a_gpu_asked_for_and_absent_runs_on_the_cpu(models):
    g = export.hdr_groups(16, 12)
    ref = predictor.load_predictor(models["unet"], runtime="torch", device="cpu").predict(g)
    for dev in ("cuda", "mps", "auto"):
        t = predictor.load_predictor(models["unet"], runtime="torch", device=dev)
        o = predictor.load_predictor(models["unet"], runtime="onnx", device=dev)
        if not torch.cuda.is_available():
            assert t.device == "cpu" and o.device == "cpu"
            assert ort_backend.providers(dev)[-1] == "CPUExecutionProvider"
            np.testing.assert_array_equal(t.predict(g), ref)
            assert export.bound_ratio(t, g, ref, o.predict(g)) <= 1.0
        if dev != "auto" and t.device == "cpu":
            assert dev.upper() in t.device_note.upper() and "CPU" in t.device_note
    with pytest.raises(UserError, match="precision on cpu must be one of"):
        predictor.load_predictor(models["unet"], runtime="torch", device="cpu", precision="fp16")
    if not torch.cuda.is_available():  # half precision asked for with the absent GPU: the CPU's fp32, said so
        t = predictor.load_predictor(models["unet"], runtime="torch", device="cuda", precision="fp16")
        assert (t.device, t.precision) == ("cpu", "fp32-cl") and "fp16 is a GPU precision" in t.device_note
        np.testing.assert_allclose(t.predict(g), ref, rtol=1e-5, atol=1e-6)


def test_gpu_script_runs_on_the_cpu_without_a_gpu_and_reports_parity():
    import subprocess
    import sys
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "gpu_infer.py"), "--size", "48x32", "--repeats", "1"],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert p.returncode == 0, p.stderr[-3000:]
    d = json.loads(p.stdout.strip().splitlines()[-1])
    assert set(d["runs"]) == {"torch cpu fp32", "torch cuda fp32", "torch cuda fp16", "onnxruntime cpu", "onnxruntime cuda"}
    for name, r in d["runs"].items():
        assert "error" not in r, (name, r)
        assert r["max_ratio_vs_cpu"] <= 1.0 and r["median_ms"] > 0, (name, r)
        if not d["cuda_available"]:
            assert r["device"] == "cpu", (name, r)


def _foreign_onnx(path: Path) -> Path:
    x = onnx.helper.make_tensor_value_info("x", onnx.TensorProto.FLOAT, [1, 3, None, None])
    y = onnx.helper.make_tensor_value_info("y", onnx.TensorProto.FLOAT, [1, 3, None, None])
    graph = onnx.helper.make_graph([onnx.helper.make_node("Relu", ["x"], ["y"])], "relu", [x], [y])
    onnx.save(onnx.helper.make_model(graph, opset_imports=[onnx.helper.make_opsetid("", 17)], ir_version=8), str(path))
    return path


def _with_meta(src: Path, dst: Path, **changes) -> Path:
    m = onnx.load(str(src))
    for p in m.metadata_props:
        if p.key in changes:
            p.value = json.dumps(changes[p.key])
    onnx.save(m, str(dst))
    return dst


def test_corrupt_foreign_and_older_onnx_files_get_clear_errors(tmp_path):
    shipped = SHIPPED.with_suffix(".onnx")
    cut = tmp_path / "cut.onnx"
    cut.write_bytes(shipped.read_bytes()[:5000])
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(bytes(range(256)) * 40)
    cases = {
        cut: r"cut\.onnx: not a readable ONNX model \(onnxruntime: Protobuf parsing failed\.\)$",
        junk: r"junk\.onnx: not a readable ONNX model",
        _foreign_onnx(tmp_path / "relu.onnx"): r"relu\.onnx: not an SSGI model \(an ONNX file without SSGI metadata",
        _with_meta(shipped, tmp_path / "v0.onnx", ssgi_onnx=0):
            r"v0\.onnx: SSGI ONNX export version 0 is not 1; export the model again",
        _with_meta(shipped, tmp_path / "spec0.onnx", format_version=0):
            r"spec0\.onnx: model was trained on channel spec v0 .* retrain it or update SSGI",
        tmp_path / "missing.onnx": r"missing\.onnx: no such model file",
    }
    for path, msg in cases.items():
        with pytest.raises(UserError, match=msg) as e:
            predictor.load_predictor(path)
        assert "\n" not in str(e.value)


def test_export_refuses_what_it_cannot_write(tmp_path):
    with pytest.raises(UserError, match=r"an ONNX file name ends in \.onnx"):
        export.export(SHIPPED, tmp_path / "x.pt")
    with pytest.raises(UserError, match="does not exist"):
        export.export(SHIPPED, tmp_path / "nope" / "x.onnx")
    bad = tmp_path / "bad.pt"
    bad.write_text("hello")
    with pytest.raises(UserError, match="bad.pt: not an SSGI model checkpoint"):
        export.export(bad, tmp_path / "x.onnx")
    assert not list(tmp_path.glob("*.onnx")) and not list(tmp_path.glob(".*tmp"))
