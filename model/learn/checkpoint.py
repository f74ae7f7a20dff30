"""Checkpoints (bpy-free): save, load, make, build_net. Running a model is ``model/infer/predictor.py``.

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

from .. import channels as ch, cliargs, files
from . import network
from .. import normalize
from ..errors import UserError

CHECKPOINT_VERSION = 1


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
    """Read a checkpoint; a UserError names the file, and says what it is, if it is not an SSGI checkpoint."""
    path = Path(path)
    fault = cliargs.model_file_fault(path)
    if fault:
        raise UserError(f"{path}: {fault}")
    try:
        d = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, ValueError, OSError, AttributeError, KeyError,
            ImportError, TypeError, IndexError, UnicodeDecodeError) as e:
        if "weights_only" in str(e):  # torch's advice to load it unsafely: not for a model from elsewhere
            raise UserError(f"{path}: not an SSGI model checkpoint (a torch file holding Python objects other than "
                            f"tensors and plain data; SSGI checkpoints hold only those, and SSGI does not run code "
                            f"from a model file)") from None
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
    from ..infer.contract import check_versions
    check_versions(d, path)
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
