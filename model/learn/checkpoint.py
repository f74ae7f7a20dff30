"""Checkpoints and the Predictor (bpy-free).

A checkpoint is a ``torch.save`` file of plain data (loaded with ``weights_only=True``: no code runs on load):

    ssgi_checkpoint  CHECKPOINT_VERSION
    kind             "network" | "linear"
    arch             the architecture dict (network.arch_for); ``network.build(arch)`` rebuilds the module
    inputs           the input spec (tuple of group names), channel_spec (channels.describe()),
                     normalization (normalize.describe()), format_version (channels.FORMAT_VERSION)
    state_dict       the weights
    history          one dict per epoch: epoch, step, minutes, loss, val_psnr, val_tm_psnr, lr, ...
    best             the history entry of these weights
    dataset          the dataset's identity (data.DatasetFolder.identity) and ``split`` {train, val} scenes
    command          the exact command line that made it
    created, versions
    train_state      (only in the ``.last.pt`` resume file) optimizer, RNG states, step, epoch, elapsed

Files are written atomically (``files.atomic_write``).
"""
from __future__ import annotations

import datetime
import pickle
import sys
from pathlib import Path

import numpy as np
import torch

from .. import channels as ch, files
from . import network
from .. import normalize
from ..errors import UserError

CHECKPOINT_VERSION = 1
OUTPUT_BOUND = 64.0  # a prediction never exceeds OUTPUT_BOUND * max(1, brightest input light value)
DEFAULT_TILE = 1024
PRECISIONS = ("fp32", "fp32-cl", "bf16-cl")


def last_path(model_path) -> Path:
    """The resume file beside ``MODEL``: ``model.pt`` -> ``model.last.pt``."""
    p = Path(model_path)
    return p.with_name(p.stem + ".last" + (p.suffix or ".pt"))


def curve_path(model_path) -> Path:
    p = Path(model_path)
    return p.with_name(p.stem + ".curve.png")


def _finite_state(sd: dict) -> bool:
    return all(torch.isfinite(v).all() for v in sd.values() if torch.is_tensor(v) and v.is_floating_point())


def make(net, kind: str, history=None, best=None, dataset=None, command=None, train_state=None, extra=None) -> dict:
    sd = {k: v.detach().clone().cpu() for k, v in net.state_dict().items()}
    spec = tuple(net.arch["inputs"])
    d = dict(ssgi_checkpoint=CHECKPOINT_VERSION, kind=kind, arch=dict(net.arch), inputs=list(spec),
             channel_spec=ch.describe(), normalization=normalize.describe(), format_version=ch.FORMAT_VERSION,
             state_dict=sd, history=list(history or []), best=dict(best or {}), dataset=dict(dataset or {}),
             command=command if command is not None else " ".join(sys.argv),
             created=datetime.datetime.now().isoformat(timespec="seconds"),
             versions=dict(torch=str(torch.__version__), numpy=str(np.__version__), python=sys.version.split()[0]),
             params=network.count_params(net), receptive_field=int(net.receptive_field))
    if train_state is not None:
        d["train_state"] = train_state
    if extra:
        d.update(extra)
    return d


def save(path, ckpt: dict) -> None:
    """Write atomically. Refuses weights with a NaN or Inf (the previous file stays)."""
    if not _finite_state(ckpt["state_dict"]):
        raise UserError(f"{path}: refusing to save non-finite weights (the last good checkpoint is kept)")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    files.atomic_write(path, lambda tmp: torch.save(ckpt, tmp))


def load(path) -> dict:
    """Read a checkpoint; a UserError names the file if it is not an SSGI checkpoint."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such model file")
    try:
        d = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, ValueError, OSError, AttributeError, KeyError,
            ImportError, TypeError, IndexError, UnicodeDecodeError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"{path}: not an SSGI model checkpoint (torch could not read it: {first[:200]})") from None
    if not isinstance(d, dict) or "ssgi_checkpoint" not in d:
        raise UserError(f"{path}: not an SSGI model checkpoint (a torch file without SSGI metadata)")
    v = d["ssgi_checkpoint"]
    if v != CHECKPOINT_VERSION:
        raise UserError(f"{path}: SSGI checkpoint version {v} is not {CHECKPOINT_VERSION}; retrain or update SSGI")
    for k in ("arch", "state_dict", "inputs"):
        if k not in d:
            raise UserError(f"{path}: SSGI checkpoint lacks {k!r}")
    fv, nv = d.get("format_version"), (d.get("normalization") or {}).get("version")
    if fv != ch.FORMAT_VERSION or nv != normalize.DESCRIPTION["version"]:
        raise UserError(f"{path}: model was trained on channel spec v{fv} with normalisation v{nv}; this SSGI reads "
                        f"v{ch.FORMAT_VERSION} with v{normalize.DESCRIPTION['version']}: retrain it or update SSGI")
    return d


def build_net(ckpt: dict, path="checkpoint") -> torch.nn.Module:
    """The module of a checkpoint with its weights; UserError when the weights do not fit the architecture."""
    try:
        net = network.build(ckpt["arch"])
    except UserError as e:
        raise UserError(f"{path}: unsupported architecture: {e}") from None
    try:
        net.load_state_dict(ckpt["state_dict"])
    except RuntimeError as e:
        lines = [l.strip() for l in str(e).splitlines() if l.strip()]
        raise UserError(f"{path}: weights do not match architecture {ckpt['arch'].get('variant')!r} "
                        f"({'; '.join(lines[1:3])[:300]})") from None
    return net.eval()


def tiled_forward(net, x: torch.Tensor, tile: int | None = DEFAULT_TILE) -> torch.Tensor:
    """``net(x)`` for a 1 x C x H x W input, in tiles of ``tile`` (core) pixels when the image is larger.

    Each tile is extended by ``network.overlap_for(net)`` (>= the receptive field) on every side and starts on
    a multiple of the network's stride, so the kept core of every tile equals the untiled result."""
    H, W = x.shape[-2:]
    m = getattr(net, "multiple", 1)
    ov = network.overlap_for(net)
    if tile is None or (H <= tile + 2 * ov and W <= tile + 2 * ov):
        return net(x)
    tile = max(m, (int(tile) // m) * m)
    ph, pw = (-H) % m, (-W) % m
    xp = torch.nn.functional.pad(x, (0, pw, 0, ph), mode="replicate") if (ph or pw) else x
    Hp, Wp = xp.shape[-2:]
    out = torch.empty(x.shape[0], 3, Hp, Wp, dtype=torch.float32)
    for y0 in range(0, Hp, tile):
        y1 = min(Hp, y0 + tile)
        for x0 in range(0, Wp, tile):
            x1 = min(Wp, x0 + tile)
            a0, a1 = max(0, y0 - ov), min(Hp, y1 + ov)
            b0, b1 = max(0, x0 - ov), min(Wp, x1 + ov)
            o = net(xp[..., a0:a1, b0:b1].contiguous())
            out[..., y0:y1, x0:x1] = o[..., y0 - a0:y1 - a0, x0 - b0:x1 - b0].float()
    return out[..., :H, :W]


class Predictor:
    """A loaded model. ``predict(groups)`` -> HxWx3 float32 linear HDR RGB, finite, >= 0, any size.

    ``groups``: {group name: HxWxC float32} holding at least ``required`` (the stored groups the input spec
    needs). Non-finite inputs are repaired by normalize's rule; ``last_repaired`` holds the pixel count.
    The output is clamped to [0, OUTPUT_BOUND * max(1, brightest value of the input light groups)], and is 0
    where the input albedo is black (diffuse surfaces with zero albedo reflect nothing; the demod/residual
    heads do this by construction, the plain log head needs the rule: issue 7, case 4).
    ``num_threads`` sets torch's (process-wide) thread count before each prediction when given.
    ``precision``: ``fp32-cl`` (default: float32 in channels_last memory format, 1.2-1.6x faster than NCHW
    here, same numbers up to summation order), ``fp32`` (NCHW) or ``bf16-cl`` (convolutions in bfloat16 under
    torch.autocast, using the CPU's AMX units; head and output in float32).
    """

    def __init__(self, net, ckpt: dict, path=None, num_threads: int | None = None, tile: int | None = DEFAULT_TILE,
                 precision: str = "fp32-cl"):
        if precision not in PRECISIONS:
            raise UserError(f"precision must be one of {', '.join(PRECISIONS)}, not {precision!r}")
        self.precision = precision
        if precision != "fp32":
            net = net.to(memory_format=torch.channels_last)
        self.net = net
        self.ckpt = ckpt
        self.path = str(path) if path is not None else "model"
        self.spec: tuple[str, ...] = tuple(ckpt["inputs"])
        self.required: tuple[str, ...] = ch.required_groups(self.spec)
        self.arch = dict(ckpt["arch"])
        self.kind = ckpt.get("kind", "network")
        self.num_threads = num_threads
        self.tile = tile
        self.last_repaired = 0
        self.receptive_field = int(net.receptive_field)

    @property
    def best(self) -> dict:
        return dict(self.ckpt.get("best", {}))

    def check_groups(self, groups) -> None:
        missing = normalize.missing_groups(self.spec, groups)
        if missing:
            raise UserError(f"{self.path}: model input spec {ch.format_spec(self.spec)} needs group(s) "
                            f"{', '.join(missing)}, which the input lacks (it has: {', '.join(sorted(groups)) or 'none'})")

    def predict(self, groups: dict[str, np.ndarray], tile: int | None = -1) -> np.ndarray:
        self.check_groups(groups)
        shapes = {tuple(np.shape(groups[g])[:2]) for g in self.required}
        if len(shapes) != 1:
            raise UserError(f"{self.path}: input groups have different sizes {sorted(shapes)}")
        x, self.last_repaired = normalize.to_inputs(groups, self.spec)
        if self.num_threads:
            torch.set_num_threads(int(self.num_threads))
        xt = torch.from_numpy(x).permute(2, 0, 1)[None]  # HxWxC memory: already channels_last
        xt = xt.contiguous(memory_format=torch.contiguous_format if self.precision == "fp32" else torch.channels_last)
        with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=self.precision == "bf16-cl"):
            out = tiled_forward(self.net, xt, self.tile if tile == -1 else tile)
        with torch.inference_mode():
            lin = network.to_linear(out.float())[0].permute(1, 2, 0).contiguous().numpy()
        lights = [g for g in self.spec if ch.GROUPS.get(g) is None or ch.GROUPS[g].kind == "light"]
        if lights:
            rep, _ = normalize.repair({g: groups[g] for g in ch.required_groups(tuple(lights))})
            peak = max(float(np.max(normalize.derived(g, rep) if g in ch.DERIVED else rep[g], initial=0.0)) for g in lights)
            np.minimum(lin, np.float32(OUTPUT_BOUND * max(1.0, peak)), out=lin)
        if "albedo" in self.required:
            lin[~(np.asarray(groups["albedo"]) > 0).any(axis=-1)] = 0.0
        return np.ascontiguousarray(lin, dtype=np.float32)


def load_predictor(path, num_threads: int | None = None, tile: int | None = DEFAULT_TILE,
                   precision: str = "fp32-cl") -> Predictor:
    ckpt = load(path)
    return Predictor(build_net(ckpt, path), ckpt, path=path, num_threads=num_threads, tile=tile, precision=precision)
