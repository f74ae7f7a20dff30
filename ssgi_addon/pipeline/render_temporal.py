"""The temporal mode of the render path: which earlier frames a frame blends, where their stateless
predictions come from, and the blend itself (model/infer/temporal.py, model/infer/history.py).

- Setting: ``"auto"`` (on when the session renders more than one frame), ``"on"``, ``"off"``: the session's
  ``temporal`` argument (``cli.py render --temporal``), else the SSGI node's ``ssgi_temporal``, else auto.
- Frame t blends the reprojected stateless predictions of t-1 .. t-k (``temporal.WINDOW``), never of a frame
  before the scene's ``frame_start`` ("the first frame" is frame_start, whatever order frames are rendered in),
  and never across a camera cut (the camera of a frame, ``camera_at``: the timeline markers bound to cameras, as
  Blender switches them; the window stops at the first earlier frame with another camera).
- A missing predecessor (frames out of order, a resumed run) is rendered and predicted then, exactly as its own
  frame would be (the same passes at the same settings), and cached (``HistoryCache``: beside the output
  frames in ``.ssgi_history/``, or in the temporary folder when nothing is written; in memory only when the
  scene is not a saved file, or was changed since in the UI).
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from ...model import channels as ch
from ...model.errors import UserError
from ...model.infer import history as hist, temporal as tp

SETTINGS = ("auto", "on", "off")
NODE_PROP = "ssgi_temporal"
CACHE_DIR = ".ssgi_history"


def check_setting(value: str, what: str = "temporal") -> str:
    v = str(value).strip().lower()
    if v not in SETTINGS:
        raise UserError(f"{what} {value!r}: expected one of {', '.join(SETTINGS)}")
    return v


def resolve(scene, override: str | None, n_frames: int) -> bool:
    """Whether the temporal mode is on for a session of ``n_frames`` frames."""
    from ..blender import node as ssgi_node
    value = override
    if not value:
        value = next((str(n.get(NODE_PROP, "")) for n in ssgi_node.ssgi_nodes(scene.compositing_node_group)
                      if n.get(NODE_PROP, "")), "auto")
    v = check_setting(value, "temporal" if override else f"SSGI node setting {NODE_PROP}")
    return v == "on" or (v == "auto" and n_frames > 1)


def camera_at(scene, frame: int):
    """The camera Blender renders frame ``frame`` with: the camera of the last camera-bound timeline marker
    at or before it (before the first such marker: the first marker's), else ``scene.camera``."""
    marks = sorted((m for m in scene.timeline_markers if m.camera is not None), key=lambda m: m.frame)
    if not marks:
        return scene.camera
    before = [m for m in marks if m.frame <= frame]
    return (before[-1] if before else marks[0]).camera


def history_frames(scene, frame: int, window: int, start: int | None = None) -> list[int]:
    """t-1, ..., t-window, none before the shot's first frame (``start``, else ``scene.frame_start``) and none across
    a camera cut."""
    cam = camera_at(scene, frame)
    first = scene.frame_start if start is None else int(start)
    out = []
    for f in range(frame - 1, frame - 1 - window, -1):
        if f < first or camera_at(scene, f) != cam:
            break
        out.append(f)
    return out


class History:
    """The temporal state of one RenderSession: the cache and the blend."""

    def __init__(self, session, window: int = tp.WINDOW, weights=None):
        self.s = session
        self.window = int(window)
        self.weights = list(weights) if weights is not None else [tp.HISTORY_WEIGHT] * self.window
        scene = session.scene
        r = scene.render
        blend = bpy.data.filepath
        # the file on disk identifies the scene unless the artist changed it since (the UI); in background mode
        # (cli.py) the only changes are the render path's own (setup, output format), which predict the same
        saved = bool(blend) and Path(blend).is_file() and (bpy.app.background or not bpy.data.is_dirty)
        key = hist.cache_key(
            model=hist.file_sha256(session.predictor.path), blend=blend,
            blend_mtime=Path(blend).stat().st_mtime_ns if saved else f"unsaved-{id(bpy.data)}-{time.time_ns()}",
            scene=scene.name, size=(r.resolution_x, r.resolution_y, r.resolution_percentage),
            samples=session.samples, working_res=session.working_res, groups=list(session.groups),
            passes=session.pass_options)
        if not saved:  # nothing identifies the scene on disk: its history stays in memory (a resume renders it)
            folder = None
        elif session.write:
            from .render import output_path
            folder = output_path(scene, session.frames[0], session.out, single=len(session.frames) == 1).parent
            folder = folder / CACHE_DIR
        else:
            folder = Path(tempfile.gettempdir()) / "ssgi-history"
        self.cache = hist.HistoryCache(folder, key, keep=self.window + 1)

    def _entry(self, frame: int, info: dict) -> dict:
        e = self.cache.get(frame)
        if e is None:
            t0 = time.perf_counter()
            groups, part = self.s._stateless(frame)
            e = self.cache.put(frame, hist.make_entry(part, groups, self._albedo(groups), self._signed))
            info.setdefault("history_rendered", []).append(frame)
            info["t_history_render"] = info.get("t_history_render", 0.0) + time.perf_counter() - t0
        return e

    def prepare(self, frame: int, info: dict) -> list[dict]:
        """The entries of the frames ``frame`` blends (rendering the missing ones), t-1 first."""
        frames = history_frames(self.s.scene, frame, self.window, getattr(self.s, "shot_start", None))
        info["history_frames"] = frames
        return [self._entry(f, info) for f in frames]

    def apply(self, frame: int, part, groups: dict, entries: list[dict], info: dict):
        """Cache frame ``frame``'s own stateless entry; return its blended diffuse part."""
        t0 = time.perf_counter()
        own = self.cache.put(frame, hist.make_entry(part, groups, self._albedo(groups), self._signed))
        cur = {g: own[g] for g in ("depth", "normal", "albedo", "direct_light") if g in own}
        warped = tp.reproject_window(entries, own["vector"], cur) if entries else []
        out = tp.blend(part, self._albedo(groups), warped, self.weights[:len(warped)],
                       geometry=groups["albedo"][..., :3].max(-1) > tp.EPS, signed=self._signed)
        info["t_temporal"] = time.perf_counter() - t0
        info["history_coverage"] = [float((w > 0.5).mean()) for _, w in warped]
        return out

    @property
    def _signed(self) -> bool:
        """A ref_combined model's part may be negative (the light it takes from EEVEE's image): kept so."""
        return ch.signed_part(self.s.target)

    def _albedo(self, groups: dict):
        """What the prediction is divided by to give light: the albedo for a diffuse-part model; ones for a
        whole-image model (its image is blended as it is)."""
        if ch.adds_part(self.s.target):
            return groups["albedo"]
        return np.ones(groups["albedo"].shape[:2] + (3,), np.float32)

    def finish(self) -> None:
        self.cache.clear()
