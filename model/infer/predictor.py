"""The torch runtime of the inference contract, and ``load_predictor``, which picks the runtime (bpy-free).

``load_predictor(path)`` -> a predictor; ``.predict({group: HxWxC float32})`` -> HxWx3 float32 linear HDR RGB,
finite, >= 0, any size. Steps 1, 2 and 4 of the contract (check, repair + normalise, pad + tiles, bound and
masks) are ``contract.ContractPredictor``'s, shared with the onnxruntime runtime (``onnx.OrtPredictor``);
``Predictor`` here adds step 3 in torch: the network and ``network.to_linear``, in the chosen precision
(``PRECISIONS`` on the CPU, ``GPU_PRECISIONS`` on CUDA/MPS) and device (``DEVICES``).

Runtimes (``load_predictor(runtime=...)``, contract.RUNTIMES): ``torch`` runs the checkpoint; ``onnx`` runs
``M.onnx`` (given, or the export beside ``M.pt`` made from that very file: its metadata holds the .pt's sha256);
``auto`` takes onnxruntime when it is importable and such an .onnx exists (2.0x faster than torch at 240x135 on 2
threads, within noise at 960x540 and 1080p: docs/onnx.md) unless torch can use a GPU that onnxruntime cannot,
else torch, else says what is missing.

Every consumer calls this: the render path (ssgi_addon/pipeline/render.py), ``cli.py predict``
(infer/predict.py), the benchmark (infer/bench.py), the fit's node scores (learn/fit.py) and the report.
A temporal filter after prediction wraps ``predict``: it sees the groups (motion from depth and normals) and the
linear output of each frame, and returns the filtered linear output, before the node composites the world.

torch is imported inside functions, so that this module (and ``load_predictor``'s onnxruntime path) works in a
Blender without torch.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UserError
from . import contract
from .contract import DEFAULT_TILE, OUTPUT_BOUND, ContractPredictor  # noqa: F401  (public names of this module)

PRECISIONS = ("fp32", "fp32-cl", "bf16-cl")  # on the CPU
GPU_PRECISIONS = ("fp32", "fp16")  # on CUDA / MPS (fp16: torch.autocast; exp/log run in float32 there)
DEVICES = contract.DEVICES


def torch_device(pref: str = "auto") -> tuple[str, str]:
    """(device, note) for a preference in DEVICES: ``auto`` takes CUDA, then MPS, then the CPU; a GPU that is
    asked for and absent falls back to the CPU with a note (never an error)."""
    import torch
    if pref not in DEVICES:
        raise UserError(f"device must be one of {', '.join(DEVICES)}, not {pref!r}")
    cuda = torch.cuda.is_available()
    mps = bool(getattr(torch.backends, "mps", None) and torch.backends.mps.is_available())
    if pref == "auto":
        return ("cuda" if cuda else "mps" if mps else "cpu"), ""
    if pref == "cuda" and not cuda:
        return "cpu", "CUDA was asked for and torch sees no CUDA device: running on the CPU"
    if pref == "mps" and not mps:
        return "cpu", "MPS was asked for and torch sees no MPS device: running on the CPU"
    return pref, ""


def tiled_forward(net, x, tile: int | None = DEFAULT_TILE):
    """``net(x)`` for a 1 x C x H x W torch tensor, in tiles of ``tile`` (core) pixels when the image is larger
    (contract.tile_plan: the kept core of every tile equals the untiled result)."""
    import torch
    H, W = x.shape[-2:]
    m = getattr(net, "multiple", 1)
    ov = contract.overlap(net.receptive_field, m)
    if tile is None or (H <= tile + 2 * ov and W <= tile + 2 * ov):
        return net(x)
    ph, pw = (-H) % m, (-W) % m
    xp = torch.nn.functional.pad(x, (0, pw, 0, ph), mode="replicate") if (ph or pw) else x
    out = torch.empty(x.shape[0], 3, *xp.shape[-2:], dtype=torch.float32)
    for ry, rx, wy, wx in contract.tile_plan(xp.shape[-2], xp.shape[-1], tile, m, ov):
        o = net(xp[..., wy, wx].contiguous())
        out[..., ry, rx] = o[..., ry.start - wy.start:ry.stop - wy.start, rx.start - wx.start:rx.stop - wx.start].float()
    return out[..., :H, :W]


class Predictor(ContractPredictor):
    """A checkpoint run by torch (contract.ContractPredictor has the contract's rules).

    ``num_threads`` sets torch's (process-wide) thread count before each prediction when given.
    ``device``: DEVICES (``auto``: CUDA, MPS, else the CPU; ``device_note`` says when a GPU asked for is absent).
    ``precision`` on the CPU: ``fp32-cl`` (the default: float32 in channels_last memory format, 1.2-1.6x faster
    than NCHW here, same numbers up to summation order), ``fp32`` (NCHW) or ``bf16-cl`` (convolutions in
    bfloat16 under torch.autocast, using the CPU's AMX units; head and output in float32); on a GPU ``fp16``
    (the default there: autocast float16) or ``fp32``. ``auto`` picks the default of the device.
    """

    runtime = "torch"

    def __init__(self, net, ckpt: dict, path=None, num_threads: int | None = None, tile: int | None = DEFAULT_TILE,
                 precision: str = "auto", device: str = "cpu"):
        import torch
        super().__init__(ckpt, path=path, tile=tile)
        self.device, self.device_note = torch_device(device)
        gpu = self.device != "cpu"
        allowed = GPU_PRECISIONS if gpu else PRECISIONS
        if precision == "auto" or (not gpu and self.device_note and precision in GPU_PRECISIONS):
            if precision not in ("auto", "fp32"):  # fp16 asked for with the GPU that is absent: the CPU's default
                self.device_note += f"; {precision} is a GPU precision: fp32-cl on the CPU"
            precision = "fp32" if precision == "fp32" else "fp16" if gpu else "fp32-cl"
        if precision not in allowed:
            raise UserError(f"precision on {self.device} must be one of {', '.join(allowed)}, not {precision!r}")
        self.precision = precision
        if precision != "fp32":
            net = net.to(memory_format=torch.channels_last)
        self.net = net.to(self.device)
        self.num_threads = num_threads
        self.receptive_field = int(net.receptive_field)
        self.multiple = int(getattr(net, "multiple", 1))

    def _forward(self, x: np.ndarray) -> np.ndarray:
        import torch

        from ..learn import network
        if self.num_threads:
            torch.set_num_threads(int(self.num_threads))
        xt = torch.from_numpy(x).to(self.device)
        xt = xt.contiguous(memory_format=torch.contiguous_format if self.precision == "fp32" else torch.channels_last)
        half = {"bf16-cl": torch.bfloat16, "fp16": torch.float16}.get(self.precision)
        with torch.inference_mode(), torch.autocast(self.device if self.device != "mps" else "mps",
                                                    dtype=half or torch.float32, enabled=half is not None):
            out = self.net(xt)
        with torch.inference_mode():
            return network.to_linear(out.float()).cpu().contiguous().numpy()


def _torch_predictor(path, num_threads, tile, precision, device):
    try:
        from ..learn import checkpoint
    except ImportError as e:
        raise UserError(f"{path}: running a .pt model needs PyTorch, which this Python lacks ({e}); "
                        f"use its ONNX export (cli.py export --model {path}) or install torch") from None
    ckpt = checkpoint.load(path)
    return Predictor(checkpoint.build_net(ckpt, path), ckpt, path=path, num_threads=num_threads, tile=tile,
                     precision=precision, device=device)


def load_predictor(path, num_threads: int | None = None, tile: int | None = DEFAULT_TILE,
                   precision: str = "auto", runtime: str = "auto", device: str = "auto"):
    """The predictor of the model file ``path`` (.pt checkpoint or .onnx export) in ``runtime``
    (contract.RUNTIMES, module doc) on ``device`` (DEVICES; the CPU when that is all there is)."""
    from . import onnx as ort_backend
    if runtime not in contract.RUNTIMES:
        raise UserError(f"runtime must be one of {', '.join(contract.RUNTIMES)}, not {runtime!r}")
    if device not in DEVICES:
        raise UserError(f"device must be one of {', '.join(DEVICES)}, not {device!r}")
    path = Path(path)
    if ort_backend.is_onnx_file(path):
        if runtime == "torch":
            raise UserError(f"{path}: an ONNX model runs in onnxruntime, not torch; give the .pt checkpoint")
        return ort_backend.load(path, num_threads=num_threads, tile=tile, device=device)
    if runtime == "torch":
        return _torch_predictor(path, num_threads, tile, precision, device)
    export = ort_backend.export_of(path)  # the .onnx beside it, exported from exactly this file, or None
    if runtime == "onnx":
        if export is None:
            raise UserError(f"{path}: no ONNX export of this file beside it ({path.with_suffix('.onnx').name} is "
                            f"missing or was exported from another checkpoint); make it with "
                            f"`cli.py export --model {path}`")
        return ort_backend.load(export, num_threads=num_threads, tile=tile, device=device)
    torch_ok = torch_importable()
    if export is not None and ort_backend.available():
        if not (torch_ok and _torch_gpu_only(device)):
            return ort_backend.load(export, num_threads=num_threads, tile=tile, device=device)
    if torch_ok:
        return _torch_predictor(path, num_threads, tile, precision, device)
    why = ("onnxruntime is not importable either" if export is not None else
           f"there is no ONNX export of it beside it (make one where torch is installed: "
           f"`cli.py export --model {path}`)")
    raise UserError(f"{path}: this Python has no PyTorch to run the checkpoint, and {why}")


_TORCH: list = []


def torch_importable() -> bool:
    """Whether ``import torch`` works here (checked once: a broken install counts as absent)."""
    if not _TORCH:
        try:
            import torch  # noqa: F401
            _TORCH.append(True)
        except Exception:  # ImportError, or a broken install (missing CUDA libraries, ...)
            _TORCH.append(False)
    return _TORCH[0]


def _torch_gpu_only(device: str) -> bool:
    """Whether torch would run on a GPU for ``device`` that onnxruntime has no provider for."""
    from . import onnx as ort_backend
    if device == "cpu":
        return False
    dev, _ = torch_device(device)
    return dev != "cpu" and not ort_backend.has_gpu_provider(dev)
