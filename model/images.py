"""Images (numpy, bpy-free): which pixels hold geometry, linear HDR to sRGB for viewing, PNG files.

- ``geometry_mask(depth, normal=None)``: HxW bool, the pixels where something was hit: a finite depth in
  (0, DEPTH_BACKGROUND) and, when the normals are given, a normal of length > 0.5 (nothing-hit pixels have a
  zero normal). The one mask of training's loss and validation, the fit, the report and the depth
  normalisation. Two rules stay apart on purpose: the ``scene`` input statistic (normalize.derived) keeps its
  own test |n.x| + |n.y| + |n.z| > 0.5 because the shipped model was trained on it (the two differ only where
  an anti-aliased edge pixel averages a normal with nothing: 0.5 <= L1 while L2 <= 0.5), and the node's
  compositing of the world (ssgi_addon/pipeline/render.world_mask) reads a live render, where "nothing hit"
  is a depth at the camera's clip end or an EEVEE alpha of 0.
- ``srgb(lin, exposure)``: the Reinhard tonemap x/(1+x) (metrics.tonemap) of ``exposure * lin``, then the sRGB
  transfer curve, as float in [0, 1]; ``srgb8`` rounds it to 8 bits. The one linear-to-display rule of
  ``cli.py predict --png``, the dataset preview, the demo and the report's figures.
- ``write_png(path, img8)``: an 8-bit RGB(A) array as a PNG, written atomically.
"""
from __future__ import annotations

import numpy as np

from . import files, metrics

DEPTH_BACKGROUND = 1e9  # depths at or above this (or non-finite, or <= 0) are "nothing hit"


def geometry_mask(depth: np.ndarray, normal: np.ndarray | None = None) -> np.ndarray:
    """HxW bool: pixels where something was hit (module doc)."""
    z = np.asarray(depth, dtype=np.float32)
    if z.ndim == 3:
        z = z[..., 0]
    with np.errstate(invalid="ignore"):
        m = (z > 0) & (z < DEPTH_BACKGROUND)  # False for NaN and +-inf
    if normal is not None:
        n = np.asarray(normal, dtype=np.float32)
        with np.errstate(invalid="ignore", over="ignore"):
            n2 = np.einsum("...i,...i->...", n, n)
        m &= (n2 > 0.25) | np.isinf(n2)  # NaN compares False
    return m


def srgb(lin, exposure: float = 1.0) -> np.ndarray:
    """HxWx3 linear HDR -> float sRGB in [0, 1] (Reinhard tonemap of metrics.tonemap, then the sRGB curve)."""
    t = metrics.tonemap(np.asarray(lin, dtype=np.float64)[..., :3] * exposure)
    return np.clip(np.where(t <= 0.0031308, 12.92 * t, 1.055 * np.power(t, 1 / 2.4) - 0.055), 0, 1)


def srgb8(lin, exposure: float = 1.0) -> np.ndarray:
    """HxWx3 linear HDR -> uint8 sRGB preview (``srgb``, rounded)."""
    return np.clip(np.round(srgb(lin, exposure) * 255), 0, 255).astype(np.uint8)


def write_png(path, img8: np.ndarray) -> None:
    from PIL import Image

    files.atomic_write(path, lambda tmp: Image.fromarray(img8).save(tmp, format="PNG"))
