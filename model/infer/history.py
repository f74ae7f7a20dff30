"""The temporal mode's per-frame history (bpy-free): each frame's *stateless* prediction, as diffuse light plus
the guides the reprojection needs, kept in memory and on disk so that frames rendered out of order, or after a
killed run, find their predecessors without rendering them again (model/infer/temporal.py says why a finite
window of stateless predictions and not a recursive filter).

An entry (``make_entry``): ``light`` HxWx3 float32 (the diffuse part / albedo), and ``depth``, ``normal``,
``albedo``, ``vector`` and, when the frame renders one, its direct light (``direct_light``: ``DIRECT_LIGHT``) as
float16 (EEVEE's passes hold half-float precision already; the camera-space normals
lose a little, which only the same-surface test sees). Entries are rounded to that form before use whether
they were just made or read back, so a frame's output does not depend on where its history came from.

On disk: ``FOLDER/KEY/NNNNNN.npz`` (``numpy.savez``, uncompressed), written to a temporary name and renamed
(model/files.py). ``KEY`` (``cache_key``) hashes everything that changes a stateless prediction: the model
file's sha256, the .blend and its modification time, the scene, the resolution, the samples, the working
resolution. About 34 bytes a pixel (40 with the direct light): 17.6-20.7 MB a frame at 960x540. A run that renders all its frames removes its
key's folder (``clear``); a killed or cancelled one leaves it for the resume.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import shutil
from pathlib import Path

import numpy as np

from .. import files

GUIDES = ("depth", "normal", "albedo", "vector", "direct_light")
# the frame's own direct light, when the frame renders one (the first found): the temporal mode's "same light" test
# (temporal.Tolerances.light): a moving object's shadow or a lamp that changes rejects history there
DIRECT_LIGHT = ("direct", "direct_soft")
_SHA: dict = {}


def file_sha256(path) -> str:
    """sha256 of a file (remembered per path, size and modification time)."""
    p = Path(path)
    st = p.stat()
    k = (str(p.resolve()), st.st_size, st.st_mtime_ns)
    if k not in _SHA:
        h = hashlib.sha256()
        with open(p, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        _SHA[k] = h.hexdigest()
    return _SHA[k]


def cache_key(**parts) -> str:
    """A short hex key of ``parts`` (JSON-able values)."""
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()[:20]


def _rounded(entry: dict) -> dict:
    out = {"light": np.ascontiguousarray(entry["light"], np.float32)}
    for g in GUIDES:
        if g in entry:
            out[g] = np.asarray(entry[g]).astype(np.float16).astype(np.float32)
    return out


def make_entry(part: np.ndarray, groups: dict, light_albedo: np.ndarray | None = None, signed: bool = False) -> dict:
    """A frame's history entry from its stateless diffuse part and its G-buffer (needs albedo; takes the
    GUIDES it finds). ``light_albedo``: what the part is divided by (default the albedo; ones for a
    whole-image model, whose prediction is blended as it is)."""
    from .temporal import light_of
    e = {"light": light_of(part, groups["albedo"] if light_albedo is None else light_albedo, signed)} \
        | {g: groups[g] for g in GUIDES if g in groups}
    for g in DIRECT_LIGHT:
        if g in groups:
            e["direct_light"] = np.asarray(groups[g], np.float32)[..., :3]
            break
    return _rounded(e)


class HistoryCache:
    """Entries by frame number: in memory (the last ``keep``) and, with a ``folder``, on disk under ``key``."""

    def __init__(self, folder, key: str, keep: int = 4):
        self.dir = Path(folder) / key if folder is not None else None
        self.keep = max(1, int(keep))
        self.memory: dict[int, dict] = {}

    def path(self, frame: int) -> Path | None:
        return self.dir / f"{int(frame):06d}.npz" if self.dir is not None else None

    def get(self, frame: int) -> dict | None:
        if frame in self.memory:
            return self.memory[frame]
        p = self.path(frame)
        if p is None or not p.is_file():
            return None
        try:
            with np.load(p) as z:
                e = {k: z[k] for k in z.files}
        except (OSError, ValueError, EOFError):  # a damaged file: made again by the caller
            with contextlib.suppress(OSError):
                p.unlink()
            return None
        e = _rounded(e)
        self._remember(frame, e)
        return e

    def _remember(self, frame: int, e: dict) -> None:
        self.memory.pop(frame, None)
        self.memory[frame] = e  # newest last; the oldest goes first
        while len(self.memory) > self.keep:
            self.memory.pop(next(iter(self.memory)))

    def put(self, frame: int, entry: dict) -> dict:
        e = _rounded(entry)
        self._remember(frame, e)
        p = self.path(frame)
        if p is not None:
            p.parent.mkdir(parents=True, exist_ok=True)
            files.sweep(p.parent, owned=lambda n: n == p.name)

            def write(tmp):
                with open(tmp, "wb") as f:
                    np.savez(f, light=e["light"], **{g: e[g].astype(np.float16) for g in GUIDES if g in e})

            files.atomic_write(p, write)
        return e

    def clear(self) -> None:
        """Remove this key's folder (a run that rendered all its frames)."""
        self.memory.clear()
        if self.dir is not None and self.dir.is_dir():
            shutil.rmtree(self.dir, ignore_errors=True)
            with contextlib.suppress(OSError):
                self.dir.parent.rmdir()  # only when no other key is left
