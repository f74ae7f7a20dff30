"""ONNX export of a checkpoint (``cli.py export``; needs torch and the ``onnx`` package, bpy-free).

The graph is the network followed by ``network.to_linear`` (onnx.py describes the file). torch's TorchScript
exporter (``dynamo=False``: no onnxscript needed) traces it at a size that is a multiple of the network's, with
H and W dynamic. ONNX has no ``expm1``/``log1p``; the exporter is given them as Kahan's accurate forms
(``expm1(x) = (u - 1) x / log u`` with ``u = exp x``, ``log1p(y) = y log u / (u - 1)`` with ``u = 1 + y``,
x and y themselves where u == 1), which keep float32 relative accuracy near 0, where ``exp(x) - 1`` loses it.

``export(model, out)`` writes atomically, then checks the file: onnxruntime through the shared contract
against the torch runtime on HDR inputs at two sizes (one not a multiple, one tiled), and refuses (removes it)
when any pixel differs by more than float32 rounding can explain: ``parity``'s ``max_ratio``, the largest
difference over the per-pixel bound of ``rounding.py`` (twice the bound of each runtime's distance from the exact
result), must be at most 1. The bound depends on the network and the pixel's values, not on the CPU, so the check
passes on any machine whose two runtimes are correct and refuses a graph that computes something else.
``max_rel`` (``rel_diff``) is reported beside it: the plain relative difference, for people.
"""
from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import numpy as np

from .. import channels as ch, files
from ..errors import UserError
from . import contract, onnx as ort_backend, rounding

OPSET = 17
# How many standard deviations of the runtimes' rounding difference a pixel may differ by (rounding.py models the
# rounding errors as independent, each within +-u of its operation's result). By Hoeffding's inequality for a sum
# of independent terms within +-c_i, P(|d| >= LAMBDA sqrt(sum c_i^2)) <= 2 exp(-LAMBDA^2 / 2): 2.5e-14 per value at
# 8, so about 1e-9 over a parity check's 1e5 values; and sum c_i^2 = 3 x the variance (a uniform term's is c^2 / 3).
LAMBDA = 8.0
REL_FLOOR = 1e-2  # radiance (linear; 1 = a white diffuse surface under unit light) below which rel_diff is absolute
_DROP = ("state_dict", "train_state")  # weights and the resume state: not metadata


def hdr_groups(w: int, h: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Synthetic inputs with HDR light: every light group times 10^U(-3, 4) per pixel (to 1e4)."""
    from .bench import synthetic_groups
    rng = np.random.default_rng(seed + 1)
    g = synthetic_groups(w, h, seed)
    for name, grp in ch.GROUPS.items():
        if name in g and grp.kind == "light":
            g[name] = (g[name] * 10.0 ** rng.uniform(-3, 4, (h, w, 1))).astype(np.float32)
    return g


def _symbolics() -> None:
    from torch.onnx import register_custom_op_symbolic

    def const(g, v):
        import torch
        return g.op("Constant", value_t=torch.tensor(v, dtype=torch.float32))

    def expm1(g, x):
        one = const(g, 1.0)
        u = g.op("Exp", x)
        um1 = g.op("Sub", u, one)
        r = g.op("Div", g.op("Mul", um1, x), g.op("Log", u))
        r = g.op("Where", g.op("Equal", um1, const(g, -1.0)), um1, r)  # exp underflowed to 0: -1
        return g.op("Where", g.op("Equal", u, one), x, r)

    def log1p(g, x):
        one = const(g, 1.0)
        u = g.op("Add", x, one)
        r = g.op("Div", g.op("Mul", g.op("Log", u), x), g.op("Sub", u, one))
        return g.op("Where", g.op("Equal", u, one), x, r)

    register_custom_op_symbolic("aten::expm1", expm1, OPSET)
    register_custom_op_symbolic("aten::log1p", log1p, OPSET)


def metadata(ckpt: dict, source: Path, multiple: int, command: str | None) -> dict[str, str]:
    """The ``metadata_props`` of an export: each plain-data key of the checkpoint as JSON, and the export's own."""
    meta = {k: v for k, v in ckpt.items() if k not in _DROP}
    meta.update(ssgi_onnx=ort_backend.ONNX_VERSION, multiple=int(multiple), source_sha256=ort_backend.sha256(source),
                source_name=source.name, export_command=command if command is not None else " ".join(sys.argv),
                opset=OPSET)
    return {k: json.dumps(v, sort_keys=True, default=str) for k, v in meta.items()}


def export(model, out=None, command: str | None = None, check: bool = True) -> dict:
    """Export checkpoint ``model`` to ``out`` (default: beside it, ``M.onnx``); summary dict."""
    import onnx
    import torch

    from ..learn import checkpoint, network
    from .predictor import Predictor

    model = Path(model)
    out = Path(out) if out else model.with_suffix(".onnx")
    if not ort_backend.is_onnx_file(out):
        raise UserError(f"--out {out}: an ONNX file name ends in .onnx")
    if not out.resolve().parent.is_dir():
        raise UserError(f"--out {out}: folder {out.resolve().parent} does not exist")
    ckpt = checkpoint.load(model)
    net = checkpoint.build_net(ckpt, model)
    m = int(getattr(net, "multiple", 1))

    class Graph(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.net = net

        def forward(self, x):
            return network.to_linear(self.net(x))

    c = ch.input_channels(tuple(ckpt["inputs"]))
    probe = torch.rand(1, c, 8 * m, 12 * m)  # a multiple: the networks' own padding is not traced
    _symbolics()

    def write(tmp):
        with warnings.catch_warnings(), torch.inference_mode(False), torch.no_grad():
            warnings.simplefilter("ignore")
            torch.onnx.export(Graph().eval(), (probe,), str(tmp), dynamo=False, opset_version=OPSET,
                              input_names=[ort_backend.INPUT], output_names=[ort_backend.OUTPUT],
                              dynamic_axes={ort_backend.INPUT: {2: "H", 3: "W"}, ort_backend.OUTPUT: {2: "H", 3: "W"}})
        proto = onnx.load(str(tmp))
        proto.doc_string = "SSGI model: normalised G-buffer (x, 1xCxHxW) -> linear RGB (y, 1x3xHxW); model/infer/onnx.py"
        del proto.metadata_props[:]
        for k, v in sorted(metadata(ckpt, model, m, command).items()):
            proto.metadata_props.add(key=k, value=v)
        onnx.checker.check_model(proto)
        onnx.save(proto, str(tmp))

    files.atomic_write(out, write)
    res = dict(out=str(out), model=str(model), bytes=out.stat().st_size, inputs=ch.format_spec(tuple(ckpt["inputs"])),
               opset=OPSET)
    if check:
        try:
            res["parity"] = parity(Predictor(net, ckpt, path=model, precision="fp32", device="cpu"),
                                   ort_backend.load(out, device="cpu"))
        except Exception:
            out.unlink(missing_ok=True)
            raise
        if not res["parity"]["max_ratio"] <= 1.0:
            out.unlink(missing_ok=True)
            raise UserError(f"{out}: the ONNX graph differs from the checkpoint by more than float32 rounding explains "
                            f"({res['parity']['max_ratio']:.3g} x the bound; {res['parity']['max_rel']:.2e} relative); "
                            f"not written")
    return res


def parity(a, b, sizes=((61, 37, None), (203, 131, 64)), seed: int = 0) -> dict:
    """Compare predictor ``b`` with the torch predictor ``a`` on HDR inputs (width, height, tile): ``max_ratio``, the
    largest per-pixel difference over ``rounding_bound`` (<= 1: within rounding), and ``max_rel``, the largest
    relative difference (``rel_diff``). A ref_combined model's prediction is compared as the image it makes
    (+ eevee_combined)."""
    worst, ratio = 0.0, 0.0
    for w, h, tile in sizes:
        g = hdr_groups(w, h, seed)
        ya, yb = a.predict(g, tile=tile), b.predict(g, tile=tile)
        ratio = max(ratio, bound_ratio(a, g, ya, yb, tile))
        if ch.signed_part(getattr(a, "target", ch.TARGET_GROUP)):
            ya, yb = ya + g["eevee_combined"][..., :3], yb + g["eevee_combined"][..., :3]
        worst = max(worst, rel_diff(ya, yb))
    return dict(max_ratio=ratio, max_rel=worst, sizes=[f"{w}x{h}" + (f" tile {t}" if t else "") for w, h, t in sizes])


def rounding_bound(pred, groups: dict, tile: int | None = None) -> np.ndarray:
    """HxWx3 float64: how far two correct float32 evaluations of torch predictor ``pred``'s ``predict(groups,
    tile)`` may differ per pixel: ``LAMBDA`` x the rounding difference's scale (rounding.py's variance of the network's
    output, for two runtimes), plus the rounding of the steps after it (the subtraction and re-addition of EEVEE's
    image for a ref_combined model: at most u |value| each)."""
    import torch

    from ..learn import network
    from .. import normalize
    from .contract import run_tiled

    class Graph(torch.nn.Module):  # the exported graph: the network, then to_linear
        def __init__(self, net):
            super().__init__()
            self.net = net

        def forward(self, x):
            return network.to_linear(self.net(x))

    graph = Graph(pred.net)
    x, _, _ = normalize.inputs_and_stats(groups, pred.spec, None)
    x = x.transpose(2, 0, 1)[None]
    e = run_tiled(lambda t: rounding.variance(graph, np.ascontiguousarray(t)), x, tile, pred.multiple, pred.overlap)
    # both runtimes round: the difference's variance is twice one runtime's
    e = LAMBDA * np.sqrt(3.0 * 2.0 * np.asarray(e, np.float64)[0].transpose(1, 2, 0))
    if ch.signed_part(pred.target):  # image - C in float32, then + C again: one rounding each, per runtime
        c = np.abs(np.asarray(groups["eevee_combined"], np.float64)[..., :3])
        y = np.abs(pred.predict(groups, tile=tile).astype(np.float64)) + c
        e += 4.0 * rounding.U * (y + c)
    return e


def bound_ratio(pred, groups: dict, ya: np.ndarray, yb: np.ndarray, tile: int | None = None,
                added: np.ndarray | None = None) -> float:
    """max over the pixels of |ya - yb| / ``rounding_bound``: at most 1 where the two differ only by float32 rounding
    (0 where both are equal, inf where they differ and the bound is 0). ``ya`` and ``yb``: ``pred.predict(groups)``
    and another evaluation of it, each plus ``added`` (HxWx3, e.g. EEVEE's other components as the node composes
    them) where given: one more rounding of each sum."""
    d = np.abs(ya[..., :3].astype(np.float64) - yb[..., :3])
    e = rounding_bound(pred, groups, tile)
    if added is not None:
        e = e + 4.0 * rounding.U * (np.abs(ya[..., :3].astype(np.float64)) + np.abs(added[..., :3]))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(d > 0, d / e, 0.0)
    return float(r.max(initial=0.0))


def rel_diff(a: np.ndarray, b: np.ndarray, floor: float = REL_FLOOR) -> float:
    """max over the pixels of |a - b| / max(|b|, floor): relative, with radiance below ``floor`` counted as
    ``floor`` (where a network's output crosses 0, float32 rounding of the convolutions is absolute, ~1e-7,
    and expm1 keeps it so: relative to a value of 1e-6 it is anything)."""
    d = np.abs(a.astype(np.float64) - b)
    return float((d / np.maximum(np.abs(b.astype(np.float64)), floor)).max(initial=0.0))
