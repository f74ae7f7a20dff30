"""The onnxruntime runtime of the inference contract (numpy + onnxruntime: no torch, no bpy).

An SSGI ONNX file (``cli.py export``, infer/export.py) holds the network and ``network.to_linear`` as one graph,
input ``x`` (1 x C x H x W, the normalised input of ``normalize.to_inputs``, H and W dynamic, multiples of the
network's ``multiple``), output ``y`` (1 x 3 x H x W, linear RGB), and the checkpoint's plain data as
``metadata_props`` (one JSON value per checkpoint key: inputs, channel_spec, normalization, arch, best,
history, dataset, command, ...) plus ``ssgi_onnx`` (ONNX_VERSION), ``multiple``, ``source_sha256`` and
``source_name`` (the .pt it came from) and ``export_command``. Everything around the graph is the contract's
(contract.ContractPredictor), the same code the torch runtime runs.

Execution providers (``providers``): the CPU always; CUDA, DirectML or CoreML first when this onnxruntime build
has them and the device preference allows; a provider that fails to start falls back to the CPU (onnxruntime's
own rule), so a missing GPU never fails a prediction.
"""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import numpy as np

from .. import channels as ch
from ..errors import UserError
from . import contract

ONNX_VERSION = 1  # the layout above; a file of another version is refused with a clear message
INPUT, OUTPUT = "x", "y"
GPU_PROVIDERS = {"cuda": ("CUDAExecutionProvider",), "mps": ("CoreMLExecutionProvider",),
                 "auto": ("CUDAExecutionProvider", "DmlExecutionProvider", "CoreMLExecutionProvider")}
_NEED = "onnxruntime (bundled with the extension; elsewhere `pip install onnxruntime`)"


def available() -> bool:
    try:
        import onnxruntime  # noqa: F401
        return True
    except Exception:  # ImportError, or a broken build
        return False


def is_onnx_file(path) -> bool:
    return Path(path).suffix.lower() == ".onnx"


def sha256(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def providers(device: str = "auto") -> list[str]:
    """The execution providers to ask for, best first, always ending with the CPU's."""
    import onnxruntime as ort
    if device not in contract.DEVICES:
        raise UserError(f"device must be one of {', '.join(contract.DEVICES)}, not {device!r}")
    have = set(ort.get_available_providers())
    return [p for p in GPU_PROVIDERS.get(device, ()) if p in have] + ["CPUExecutionProvider"]


def has_gpu_provider(device: str) -> bool:
    return available() and len(providers(device)) > 1


def _session(path: Path, num_threads: int | None = None, device: str = "cpu"):
    import onnxruntime as ort
    so = ort.SessionOptions()
    so.log_severity_level = 3  # errors only: the CPU fallback of a missing GPU provider is no warning to show
    if num_threads:
        so.intra_op_num_threads = int(num_threads)
        so.inter_op_num_threads = 1
    try:
        return ort.InferenceSession(str(path), so, providers=providers(device))
    except Exception as e:  # onnxruntime's InvalidProtobuf, Fail, InvalidGraph, NoSuchFile, ...
        raise UserError(f"{path}: not a readable ONNX model (onnxruntime: {_reason(e)})") from None


def _reason(e: Exception) -> str:
    """onnxruntime's message without its prefix, the path and the C++ source location."""
    msg = (str(e).strip().splitlines() or [type(e).__name__])[0]
    msg = msg.split(" failed:", 1)[-1]
    msg = re.sub(r"^\s*/\S+:\d+ [^(]*\([^)]*\) ", "", msg).strip()
    return msg[:200] or type(e).__name__


def read_meta(sess, path) -> dict:
    """The checkpoint's plain data from an SSGI ONNX session; UserError for another ONNX file or version."""
    props = dict(sess.get_modelmeta().custom_metadata_map)
    if "ssgi_onnx" not in props:
        raise UserError(f"{path}: not an SSGI model (an ONNX file without SSGI metadata; "
                        f"SSGI models come from `cli.py export --model M.pt`)")
    meta = {}
    for k, v in props.items():
        try:
            meta[k] = json.loads(v)
        except ValueError:
            meta[k] = v
    v = meta["ssgi_onnx"]
    if v != ONNX_VERSION:
        raise UserError(f"{path}: SSGI ONNX export version {v!r} is not {ONNX_VERSION}; export the model again "
                        f"with this SSGI (`cli.py export --model M.pt`)")
    for k in ("inputs", "arch", "multiple", "receptive_field"):
        if k not in meta:
            raise UserError(f"{path}: SSGI ONNX file lacks {k!r} in its metadata; export the model again")
    contract.check_versions(meta, path)
    names = ([i.name for i in sess.get_inputs()], [o.name for o in sess.get_outputs()])
    if names != ([INPUT], [OUTPUT]):
        raise UserError(f"{path}: graph inputs/outputs {names} are not SSGI's ([{INPUT!r}], [{OUTPUT!r}])")
    c = sess.get_inputs()[0].shape[1]
    if c != ch.input_channels(tuple(meta["inputs"])):
        raise UserError(f"{path}: graph takes {c} channels, its input spec {ch.format_spec(tuple(meta['inputs']))} "
                        f"has {ch.input_channels(tuple(meta['inputs']))}")
    return meta


def export_of(pt_path) -> Path | None:
    """``M.onnx`` beside ``M.pt`` when it was exported from exactly this file (its ``source_sha256``); None
    otherwise. Without onnxruntime the metadata cannot be read: the file is returned when it exists."""
    pt_path = Path(pt_path)
    sib = pt_path.with_suffix(".onnx")
    if not sib.is_file() or not pt_path.is_file():
        return None
    if not available():
        return sib
    try:
        meta = read_meta(_session(sib), sib)
    except UserError:
        return None
    return sib if meta.get("source_sha256") == sha256(pt_path) else None


class OrtPredictor(contract.ContractPredictor):
    """An SSGI ONNX file run by onnxruntime; the same interface as predictor.Predictor (``predict``,
    ``target``, ``inputs``/``spec``, ``required``, ``last_repaired``, ``meta``). ``device`` is the provider
    that runs it ("cpu", "cuda", "dml", "coreml")."""

    runtime = "onnx"

    def __init__(self, sess, meta: dict, path=None, tile: int | None = contract.DEFAULT_TILE):
        super().__init__(meta, path=path, tile=tile)
        self.sess = sess
        self.multiple = int(meta["multiple"])
        self.receptive_field = int(meta["receptive_field"])
        first = sess.get_providers()[0]
        self.device = {"CUDAExecutionProvider": "cuda", "DmlExecutionProvider": "dml",
                       "CoreMLExecutionProvider": "coreml"}.get(first, "cpu")

    def _forward(self, x: np.ndarray) -> np.ndarray:
        return self.sess.run([OUTPUT], {INPUT: np.ascontiguousarray(x, dtype=np.float32)})[0]


def load(path, num_threads: int | None = None, tile: int | None = contract.DEFAULT_TILE,
         device: str = "auto") -> OrtPredictor:
    from .. import cliargs
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: {cliargs.model_file_fault(path) or 'no such model file'}")
    if not available():
        raise UserError(f"{path}: running an ONNX model needs {_NEED}, which this Python lacks")
    sess = _session(path, num_threads, device)
    return OrtPredictor(sess, read_meta(sess, path), path=path, tile=tile)
