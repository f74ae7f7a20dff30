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
- ``normals_from_depth(depth, P)``: camera-space unit normals of the surfaces a depth image shows (the render
  path's one render writes no Normal pass: ssgi_addon/blender/passes.render_gbuffer).
- ``camera_points(z, nx, ny, P)``: the camera-space points that depths at normalised device coordinates show (the
  one unprojection: normals_from_depth and model/infer/lightmap.world_points).
"""
from __future__ import annotations

import numpy as np

from . import files, metrics

DEPTH_BACKGROUND = 1e9  # depths at or above this (or non-finite, or <= 0) are "nothing hit"
WORLD_DEPTH_FRACTION = 0.999  # and at or above this x the camera's clip end where it is known: EEVEE's Z pass
#                               writes about the clip end where nothing was hit (Blender 5: 500.27 for 500)


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


def camera_points(z: np.ndarray, nx: np.ndarray, ny: np.ndarray, P) -> np.ndarray:
    """...x3 camera-space points (x, y, -z) seen at normalised device coordinates ``nx``, ``ny`` (arrays that broadcast
    with ``z``) at depths ``z`` (distance along the view axis) through the camera's 4x4 projection ``P`` (OpenGL
    convention, Blender's calc_matrix_camera; perspective, ndc = (P00 x + P02 z) / -z with z = -depth, or
    orthographic, ndc = P00 x + P03). Computed in the arrays' own precision (give ``P`` as float32 for float32)."""
    P = np.asarray(P)
    if P[3, 3] == 0.0:  # perspective
        x = z * (nx + P[0, 2]) / P[0, 0]
        y = z * (ny + P[1, 2]) / P[1, 1]
    else:  # orthographic
        x = (nx - P[0, 3]) / P[0, 0]
        y = (ny - P[1, 3]) / P[1, 1]
    return np.stack(np.broadcast_arrays(x, y, -z), -1)


def _one_sided(p: np.ndarray, z: np.ndarray, axis: int) -> np.ndarray:
    """The difference of ``p`` to the next pixel along ``axis``, or to the previous one where that side's depth step is
    smaller (so that a pixel beside a silhouette takes its own surface's slope, not the jump to the other surface);
    the frame's last / first pixel takes its only side."""
    fwd = np.diff(p, axis=axis)
    dz = np.abs(np.diff(z, axis=axis))
    n = p.shape[axis]
    # (one slicer for both: ``p`` has one more, trailing, axis than ``z``, which a shorter index leaves whole)
    sl = lambda a, b: tuple(slice(a, b) if i == axis else slice(None) for i in range(z.ndim))  # noqa: E731
    out = np.empty_like(p)
    # interior: forward difference fwd[i], backward fwd[i-1]
    take_back = dz[sl(0, n - 2)] < dz[sl(1, n - 1)]
    out[sl(1, n - 1)] = np.where(take_back[..., None], fwd[sl(0, n - 2)], fwd[sl(1, n - 1)])
    out[sl(0, 1)] = fwd[sl(0, 1)]
    out[sl(n - 1, n)] = fwd[sl(n - 2, n - 1)]
    return out


def normals_from_depth(depth: np.ndarray, P, clip_end: float | None = None) -> np.ndarray:
    """HxWx3 float32 camera-space unit normals (+X right, +Y up, +Z towards the camera, facing the camera) of the
    surfaces a depth image shows: ``depth`` HxW or HxWx1 (distance along the view axis, top row first, as EEVEE's Z
    pass), ``P`` the camera's 4x4 projection at that size (OpenGL convention, Blender's calc_matrix_camera;
    perspective or orthographic). Each pixel's camera-space position is unprojected; the normal is the cross product
    of its horizontal and vertical one-sided differences (``_one_sided``). Pixels with nothing hit
    (``geometry_mask``, and with ``clip_end`` the depths at ``WORLD_DEPTH_FRACTION`` of it or beyond: EEVEE's Z pass
    there) get a zero normal, as in EEVEE's Normal pass. These are the geometric normals: flat per
    polygon where EEVEE's pass interpolates a smooth-shaded mesh's (on the artist test set at 960x540
    the two differ by a median 0.02-1.8 degrees)."""
    # (float32 throughout: neighbouring pixels' positions differ by millimetres to centimetres, float32 resolves
    # micrometres at 10 m; 0.05 s at 960x540 on this machine against 0.1 in float64)
    z = np.asarray(depth, np.float32)
    z = z[..., 0] if z.ndim == 3 else z
    P = np.asarray(P, np.float32)
    H, W = z.shape
    if H < 2 or W < 2:
        raise ValueError(f"depth image of {W}x{H} pixels: normals need at least 2x2")
    geo = geometry_mask(z)
    if clip_end is not None:
        geo &= z < np.float32(WORLD_DEPTH_FRACTION * clip_end)
    zz = np.where(geo, z, np.float32(0.0))
    nx = ((np.arange(W, dtype=np.float32) + 0.5) / W * 2.0 - 1.0)[None, :]
    ny = (1.0 - (np.arange(H, dtype=np.float32) + 0.5) / H * 2.0)[:, None]
    p = camera_points(zz, nx, ny, P)
    a, b = _one_sided(p, zz, 1), _one_sided(p, zz, 0)  # n = a x (-b)
    n = np.stack([b[..., 1] * a[..., 2] - b[..., 2] * a[..., 1], b[..., 2] * a[..., 0] - b[..., 0] * a[..., 2],
                  b[..., 0] * a[..., 1] - b[..., 1] * a[..., 0]], -1)
    length = np.sqrt(np.einsum("...i,...i->...", n, n))
    facing = (np.einsum("...i,...i->...", n, p) if P[3, 3] == 0.0 else -n[..., 2]) > 0
    scale = np.where(geo & (length > 0), np.where(facing, -1.0, 1.0) / np.maximum(length, 1e-30), 0.0)
    return (n * scale[..., None].astype(np.float32)).astype(np.float32)
