"""OpenEXR I/O for dataset samples, through the OpenEXR Python package (bpy-free).

A sample is one single-part EXR with channels ``<group>.<component>`` (see ``channels.py``), stored as half
(``float16``) or float (``float32``). Files are written atomically (``files.atomic_write``), so a killed writer never leaves a
half-written sample under its final name.
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import threading
from pathlib import Path

import numpy as np

from .. import channels as ch, files
from ..errors import UserError


def write_exr(path, planes: dict[str, np.ndarray], half: bool = True, header: dict | None = None) -> None:
    """Write ``{channel_name: HxW array}`` to ``path`` atomically."""
    import OpenEXR

    path = Path(path)
    dtype = np.float16 if half else np.float32
    chans = {}
    for name, arr in planes.items():
        a = np.ascontiguousarray(np.asarray(arr, dtype=np.float32))
        if a.ndim != 2:
            raise ValueError(f"channel {name}: expected a 2-D plane, got shape {a.shape}")
        if half:
            a = np.clip(a, -65504.0, 65504.0)  # keep +-inf out of half unless it was there
        chans[name] = OpenEXR.Channel(np.ascontiguousarray(a.astype(dtype)))
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for k, v in (header or {}).items():
        hdr[k] = str(v)

    def write(tmp):
        with OpenEXR.File(hdr, chans) as f:
            f.write(str(tmp))

    try:
        files.atomic_write(path, write)
    except RuntimeError as e:  # the binding's write errors ("Failed to write pixel data ... File too large.")
        raise OSError(f"{path}: could not write the OpenEXR file ({e})") from None


_STDOUT_LOCK = threading.RLock()  # re-entrant: blocks nest (render_cli wraps whole commands)


@contextlib.contextmanager
def stdout_to_stderr():
    """Send what C code prints on stdout to stderr meanwhile, so that stdout holds only ``--json`` summaries
    (OpenEXR's binding prints "Warning: Exception raised reading pixel data ..." there for a file cut short;
    Blender prints "Read blend: ..."). C stdio is flushed before and after moving file descriptor 1."""
    try:
        libc = ctypes.CDLL(None)
    except (OSError, TypeError):  # no process-wide C library handle (Windows): leave stdout alone
        libc = None
    if libc is None:
        yield
        return
    with _STDOUT_LOCK:
        sys.stdout.flush()
        libc.fflush(None)
        saved = os.dup(1)
        os.dup2(2, 1)
        try:
            yield
        finally:
            sys.stdout.flush()
            libc.fflush(None)
            os.dup2(saved, 1)
            os.close(saved)


def read_exr(path) -> tuple[dict[str, np.ndarray], dict]:
    """Read every channel of every part of ``path`` as float32 planes. Raises UserError naming the file."""
    import OpenEXR

    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: no such EXR file")
    try:
        declared = [c.name for part in OpenEXR.File(str(path), header_only=True).parts for c in part.header["channels"]]
        with stdout_to_stderr():
            f = OpenEXR.File(str(path), separate_channels=True)
        planes: dict[str, np.ndarray] = {}
        header: dict = {}
        for part in f.parts:
            header.update({k: v for k, v in part.header.items() if isinstance(v, (str, int, float))})
            for name, c in part.channels.items():
                planes[name] = np.asarray(c.pixels, dtype=np.float32)
    except UserError:
        raise
    except Exception as e:  # OpenEXR raises plain RuntimeError/ValueError for broken files
        raise UserError(f"{path}: not a readable OpenEXR file ({type(e).__name__}: {e})") from None
    cut = sorted(set(declared) - set(planes))  # a file cut short: OpenEXR drops the part with a printed warning
    if cut:
        raise UserError(f"{path}: truncated or corrupt OpenEXR file: the pixels of {len(cut)} channel(s) "
                        f"({', '.join(cut[:3])}{', ...' if len(cut) > 3 else ''}) could not be read")
    return planes, header


def write_sample(path, groups: dict[str, np.ndarray], half: bool = True, header: dict | None = None) -> None:
    """Write a sample: ``{group: HxWxC array}`` with C matching the channel spec."""
    planes = {}
    for name, arr in groups.items():
        g = ch.GROUPS.get(name)
        if g is None:
            raise ValueError(f"unknown group {name!r}")
        arr = np.asarray(arr)
        if arr.ndim == 2:
            arr = arr[..., None]
        if arr.shape[-1] != g.size:
            raise ValueError(f"group {name}: expected {g.size} components, got shape {arr.shape}")
        for i, c in enumerate(g.channels):
            planes[c] = arr[..., i]
    hdr = {"ssgi_format": ch.FORMAT_VERSION}
    hdr.update(header or {})
    write_exr(path, planes, half=half, header=hdr)


def read_sample(path, groups: tuple[str, ...] | None = None, strict: bool = True) -> dict[str, np.ndarray]:
    """Read ``groups`` (default: all of ``SAMPLE_GROUPS``; the ``OPTIONAL_GROUPS`` only when the file has them) from a sample as ``{group: HxWxC float32}``.

    A missing channel is a UserError naming the file and the channel; with ``strict``, so is a channel that is
    in no group of the channel spec (a foreign or newer file), whichever ``groups`` are asked for.
    """
    path = Path(path)
    planes, _ = read_exr(path)
    if groups is not None:
        want = tuple(groups)
    else:
        want = tuple(g for g in ch.SAMPLE_GROUPS
                     if g not in ch.OPTIONAL_GROUPS or any(c in planes for c in ch.GROUPS[g].channels))
    missing = [c for g in want for c in ch.GROUPS[g].channels if c not in planes]
    if missing:
        raise UserError(f"{path}: missing channel(s) {', '.join(missing)}")
    if strict:
        known = {c for g in ch.GROUPS.values() for c in g.channels}
        extra = sorted(set(planes) - known)
        if extra:
            raise UserError(f"{path}: unexpected channel(s) {', '.join(extra)} (not in channel spec v{ch.FORMAT_VERSION})")
    shapes = {planes[c].shape for g in want for c in ch.GROUPS[g].channels}
    if len(shapes) != 1:
        raise UserError(f"{path}: channels have different sizes {sorted(shapes)}")
    return {g: np.stack([planes[c] for c in ch.GROUPS[g].channels], axis=-1) for g in want}
