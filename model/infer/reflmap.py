"""A shot's reflection map: a small world-space field that corrects EEVEE's reflections, fitted to one scene's views
(bpy-free, numpy).

A diffuse-part model's image is its prediction + EEVEE's rest (compose.py), so EEVEE's own reflections bound it. On
the Cornell box shot they bound it at 33.8 dB (docs/fit.md): EEVEE's mirror ball traces its
reflections in screen space, and what the ball reflects lies mostly off screen (the walls beside and behind the
camera, the floor under the ball), where EEVEE falls back to the world (black); the ball held 71-96 % of the
ceiling's squared error. Every view of a shot sees the same room, though: what a static mirror reflects is a
function of where the surface is and which way the reflected ray leaves it. The reflection map is that function's
correction, learned from the views (model/learn/reflmap.py): an MLP of the world position (Fourier features over the
glossy pixels' box, ``NFREQ_POS`` octaves) and the world reflection direction (``NFREQ_DIR`` octaves), giving
``c`` such that ``rest + gloss x c`` is Cycles' image minus its diffuse part. ``gloss`` is EEVEE's Glossy Color pass
of the artist-settings render (channels group ``gloss``): a metal's colour, 0 on a surface that reflects nothing.

The map learns from the glossy pixels that are not an edge (lightmap.edges, with gloss in place of the albedo: an
anti-aliased silhouette mixes two surfaces, so its reflected direction is no one surface's; not the normal test,
which marks a whole small mirror ball at 96x54). At render time (``ReflectionMap.apply(rest, groups, M, P)``) it
corrects every pixel whose gloss exceeds ``GLOSS_MIN`` in some channel and where something was hit, the edges too:
a silhouette pixel's Glossy Color is already weighted by how much of it the mirror covers, and left to
EEVEE the Cornell ball's 1-2 px silhouette stayed dark (EEVEE reflects the black world at grazing angles); on the
Cornell one-render fit's 7 validation views the 1,435 edge pixels scored 19.27 dB uncorrected and 26.04 dB
corrected, and the ceiling rose from 37.13 to 39.24 dB. For those pixels
only: the world position and normal (lightmap.world_points), the view ray from the camera (``M``'s translation; orthographic cameras along ``M``'s -Z), the reflected direction, and
``rest + lam x gloss x field``. ``lam`` is chosen by the fit on its validation views; 0 means unused.

What it cannot know: a reflection that changes over the shot (a moving object seen in a mirror, a moving mirror
itself: its reflection then reads the place it passes through), and glossy surfaces no view saw. It corrects
EEVEE's reflection on average over the views; where EEVEE's screen-space trace succeeds in one frame and not in
another, the correction is right on neither. The file lives beside the model (``path_for``: ``shot.pt`` ->
``shot.reflmap.npz``), numpy only, so the ONNX path without torch uses it too.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import channels as ch
from ..errors import UserError
from . import lightmap as lm

# a ref_combined model's albedo floor: at or above it the network acts on a pixel, below it the reflection map takes
# over (apply_combined)
ALBEDO_FLOOR = ch.COMBINED_ALBEDO_FLOOR

NFREQ_POS = 3  # Fourier octaves of the position (pi * 2**i over [-1, 1]): a mirror's reflection varies little
NFREQ_DIR = 4  # ... of the reflection direction (a unit vector): walls, a panel, a room's corners
GLOSS_MIN = 0.05  # a pixel is corrected where some channel of its Glossy Color exceeds this
FORMAT = 1
KEYS = ("lo", "hi", "nfreq_pos", "nfreq_dir", "lam", "format")


def path_for(model_path) -> Path:
    """The reflection map file of a model: beside it, the model's stem + ``.reflmap.npz``."""
    p = Path(model_path)
    return p.with_name(p.stem + ".reflmap.npz")


def reflected(depth: np.ndarray, normal: np.ndarray, M, P, pixels=None) -> tuple[np.ndarray, np.ndarray]:
    """(HxWx3 world positions, HxWx3 unit world reflection directions) of a frame (``lightmap.world_points``'
    arguments; with ``pixels``, of those pixels only): the view ray from the camera to each point mirrored about
    its normal."""
    pw, nw = lm.world_points(depth, normal, M, P, pixels=pixels)
    M, P = np.asarray(M, np.float64), np.asarray(P, np.float64)
    if P[3, 3] == 0.0:  # perspective: from the camera's position
        v = pw.astype(np.float64) - M[:3, 3]
    else:  # orthographic: along the camera's -Z axis everywhere
        v = np.broadcast_to(-M[:3, 2], pw.shape).astype(np.float64)
    v /= np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)
    n = nw.astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    r = v - 2.0 * (v * n).sum(-1, keepdims=True) * n
    return pw, r.astype(np.float32)


def glossy_mask(groups: dict, edges: bool = False) -> np.ndarray:
    """HxW bool: the glossy pixels (module doc): something hit, gloss above ``GLOSS_MIN`` in some channel, and
    unless ``edges``, not a silhouette nor a gloss edge (a curved mirror's turning normals are no edge): the pixels
    the map learns from. It corrects them with the edges (``ReflectionMap.correction``)."""
    from ..images import geometry_mask
    gl = np.nan_to_num(np.asarray(groups["gloss"], np.float32)[..., :3])
    ok = geometry_mask(groups["depth"], groups["normal"]) & (gl > GLOSS_MIN).any(-1)
    if ok.any() and not edges:
        ok &= ~lm.edges(groups["depth"], groups["normal"], gl, normals=False)
    return ok


def n_features(nfreq_pos: int, nfreq_dir: int) -> int:
    return 6 + 6 * int(nfreq_pos) + 6 * int(nfreq_dir)


def corrects_combined(target: str) -> bool:
    """Whether a model of ``target`` takes its reflection map as a ref_combined model does (``apply_combined``: on
    EEVEE's GI-off image, where the albedo is black) rather than on EEVEE's rest (``apply``). The one rule for the fit
    (which pixels the map learns from and is weighed on, model/learn/reflmap.py) and the render path (how it is
    applied)."""
    return ch.base_group(target) == "eevee_combined"


def combined_weight(albedo: np.ndarray) -> np.ndarray:
    """HxWx1: how much of the map a ref_combined model's image takes (``ReflectionMap.apply_combined``): 1 where the
    albedo is black, falling to 0 where its largest channel reaches the head's floor ``ALBEDO_FLOOR``."""
    alb = np.nan_to_num(np.asarray(albedo, np.float32)[..., :3]).max(-1, keepdims=True)
    return np.clip(1.0 - alb / ALBEDO_FLOOR, 0.0, 1.0)


class ReflectionMap:
    """The fitted field: ``weights`` [(W, b), ...] of an MLP with ReLU between layers (numpy), the box ``lo``/``hi``
    of the glossy points, the octaves, the weight ``lam`` (module doc)."""

    def __init__(self, weights, lo, hi, nfreq_pos: int = NFREQ_POS, nfreq_dir: int = NFREQ_DIR, lam: float = 0.0,
                 meta: dict | None = None):
        self.weights = [(np.asarray(w, np.float32), np.asarray(b, np.float32)) for w, b in weights]
        self.lo, self.hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
        self.nfreq_pos, self.nfreq_dir, self.lam = int(nfreq_pos), int(nfreq_dir), float(lam)
        self.meta = dict(meta or {})
        din = n_features(self.nfreq_pos, self.nfreq_dir)
        if not self.weights or self.weights[0][0].shape[1] != din or self.weights[-1][0].shape[0] != 3:
            raise UserError(f"reflection map: layers {[w.shape for w, _ in self.weights]} do not map {din} "
                            "features to RGB")

    def field(self, points: np.ndarray, dirs: np.ndarray, chunk: int = 65536) -> np.ndarray:
        """Nx3 corrections (signed) at N world points reflecting along ``dirs``."""
        pts, d = np.reshape(points, (-1, 3)), np.reshape(dirs, (-1, 3))
        out = np.empty((len(pts), 3), np.float32)
        for s in range(0, len(pts), chunk):
            out[s:s + chunk] = lm.mlp(lm.encode(pts[s:s + chunk], d[s:s + chunk], self.lo, self.hi, self.nfreq_pos,
                                                self.nfreq_dir), self.weights)
        return np.nan_to_num(out, nan=0.0, posinf=0.0, neginf=0.0)

    def correction(self, groups: dict, M, P, lam: float | None = None) -> np.ndarray:
        """HxWx3: what the map adds to EEVEE's rest (``lam`` x gloss x field on ``glossy_mask(edges=True)``, 0
        elsewhere)."""
        lam = self.lam if lam is None else float(lam)
        gl = np.nan_to_num(np.asarray(groups["gloss"], np.float32)[..., :3])
        out = np.zeros(gl.shape, np.float32)
        ok = glossy_mask(groups, edges=True)
        if lam <= 0.0 or not ok.any():
            return out
        rows, cols = np.nonzero(ok)  # only the corrected pixels are placed in the world
        z = np.asarray(groups["depth"], np.float32).reshape(ok.shape)
        pw, r = reflected(z[ok], np.asarray(groups["normal"], np.float32)[..., :3][ok], M, P,
                          pixels=(cols, rows, ok.shape[1], ok.shape[0]))
        out[ok] = lam * gl[ok] * self.field(pw, r)
        return out

    def apply(self, rest: np.ndarray, groups: dict, M, P) -> np.ndarray:
        """EEVEE's ``rest`` (HxWx3) corrected: rest + ``correction``. ``lam`` 0 returns ``rest`` itself. The
        composition clamps the image at 0 (compose.py)."""
        if self.lam <= 0.0:
            return rest
        return (np.asarray(rest, np.float32)[..., :3] + self.correction(groups, M, P)).astype(np.float32)

    def apply_combined(self, combined: np.ndarray, groups: dict, M, P) -> np.ndarray:
        """A ref_combined model's base image (EEVEE's GI-off Combined, HxWx3) corrected where its network cannot
        act: the correction x (1 - max albedo / ALBEDO_FLOOR, clipped to [0, 1]), all of it where the albedo is black
        (metal, mirrors: the model's image is EEVEE's there), none where the albedo reaches the head's floor (the
        network learned Cycles' image there, reflections included: corrected again, they would count twice)."""
        c = np.asarray(combined, np.float32)[..., :3]
        if self.lam <= 0.0:
            return c
        return (c + combined_weight(groups["albedo"]) * self.correction(groups, M, P)).astype(np.float32)

    # --- the file ---

    def save(self, path) -> Path:
        return lm.save_field(path, self.weights, self.meta, lo=self.lo, hi=self.hi, nfreq_pos=np.int64(self.nfreq_pos),
                             nfreq_dir=np.int64(self.nfreq_dir), lam=np.float64(self.lam), format=np.int64(FORMAT))

    @classmethod
    def load(cls, path) -> "ReflectionMap":
        weights, z, meta = lm.load_field(path, KEYS, FORMAT, "reflection map")
        try:
            return cls(weights, z["lo"], z["hi"], int(z["nfreq_pos"]), int(z["nfreq_dir"]), float(z["lam"]), meta)
        except (ValueError, TypeError) as e:
            raise UserError(f"{path}: cannot read the reflection map ({type(e).__name__}: {e})") from None


def load_beside(model_path) -> ReflectionMap | None:
    """The model's reflection map when there is one beside it (``path_for``) and it is used (lam > 0), else None."""
    p = path_for(model_path)
    if not p.is_file():
        return None
    m = ReflectionMap.load(p)
    return m if m.lam > 0.0 else None
