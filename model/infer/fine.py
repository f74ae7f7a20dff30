"""Near emitters, the network at the output resolution (bpy-free, numpy only; issue 15, docs/working_res.md).

Why: beside an emitter tens of times brighter than its surround, the network run at 1/4 of 960x540 predicts about
twice the light the surround needs in the two blocks next to the emitter (the Cornell box's ceiling round its
panel: +0.10-0.16 on a needed 0.12-0.17, measured in docs/working_res.md), and no upsample can take that back;
the same network at full resolution does not. So the blocks that hold an emitter pixel and ``FINE_RING`` blocks
around them take the full-resolution prediction, run on crops of the full-resolution groups (each crop its box
plus the network's tile overlap of context) with the working resolution's whole-image statistics, fading into the
upsampled prediction over ``FINE_FADE`` more blocks. Used by ``workres.WorkingResolution`` (step 5).
"""
from __future__ import annotations

import numpy as np

from .workres import _blocks, _pad_mult, upsample_light

# near emitters the network runs at the output resolution (``fine_plan``, docs/working_res.md)
FINE_EMISSION = 0.01  # a pixel whose emission (max channel) is above this is an emitter (normalize's "glow" rule)
FINE_RING = 2  # working-resolution blocks around an emitter's blocks that take the full-resolution prediction
FINE_FADE = 1  # blocks beyond the ring over which it fades into the upsampled prediction
FINE_MAX_FRACTION = 0.05  # the fine windows may cover at most this share of the output pixels, else none is run


def _runs(v: np.ndarray) -> list[tuple[int, int]]:
    """[(start, stop)] of the True runs of a 1-d bool array."""
    d = np.diff(np.concatenate([[0], v.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def boxes(mask: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Boxes (y0, y1, x0, x1) covering the True cells of a 2-d mask: cut recursively along empty rows and
    columns (an XY cut), so separate objects get separate boxes and a box holds no empty row or column."""
    out, todo = [], [(0, mask.shape[0], 0, mask.shape[1])]
    while todo:
        y0, y1, x0, x1 = todo.pop()
        sub = mask[y0:y1, x0:x1]
        rows = _runs(sub.any(1))
        if len(rows) > 1:
            todo += [(y0 + a, y0 + b, x0, x1) for a, b in rows]
            continue
        if not rows:
            continue
        a, b = rows[0]
        cols = _runs(sub[a:b].any(0))
        if len(cols) > 1:
            todo += [(y0 + a, y0 + b, x0 + c, x0 + d) for c, d in cols]
        else:
            out.append((y0 + a, y0 + b, x0 + cols[0][0], x0 + cols[0][1]))
    return sorted(out)


def _chebyshev_grow(m: np.ndarray) -> np.ndarray:
    """The mask grown by one cell in all 8 directions."""
    g = m.copy()
    g[1:] |= m[:-1]
    g[:-1] |= m[1:]
    h = g.copy()
    h[:, 1:] |= g[:, :-1]
    h[:, :-1] |= g[:, 1:]
    return h


def fine_plan(emission: np.ndarray, f: int, overlap: int, multiple: int = 1) -> tuple[np.ndarray, list] | None:
    """Where the network runs at the output resolution: the blocks (working-resolution pixels) that hold an
    emitter pixel (``FINE_EMISSION``) and the ``FINE_RING`` blocks around them (weight 1), fading to 0 over
    ``FINE_FADE`` more blocks (module doc: why).

    Returns (h x w float32 block weights, [(window rows, window cols, core rows, core cols)] at the output
    resolution: each core a box of weighted blocks, each window its core plus ``overlap`` pixels of context on
    every side, clipped to the image, starting on a multiple of ``multiple``), or None where there is no emitter
    or the windows would cover more than ``FINE_MAX_FRACTION`` of the image."""
    e = np.asarray(emission, np.float32)
    e = e.max(-1) if e.ndim == 3 else e
    H, W = e.shape
    hot = _blocks(_pad_mult(e > FINE_EMISSION, f), f).any(-1)
    if not hot.any():
        return None
    wgt, m = np.zeros(hot.shape, np.float32), hot
    for _ in range(FINE_RING):
        m = _chebyshev_grow(m)
    wgt[m] = 1.0
    for k in range(1, FINE_FADE + 1):
        g = _chebyshev_grow(m)
        wgt[g & ~m] = 1.0 - k / (FINE_FADE + 1)
        m = g
    plan, px = [], 0
    for y0, y1, x0, x1 in boxes(wgt > 0):
        cy, cx = slice(y0 * f, min(H, y1 * f)), slice(x0 * f, min(W, x1 * f))
        wy0, wx0 = (max(0, c.start - overlap) // multiple * multiple for c in (cy, cx))
        wy, wx = slice(wy0, min(H, cy.stop + overlap)), slice(wx0, min(W, cx.stop + overlap))
        plan.append((wy, wx, cy, cx))
        px += (wy.stop - wy.start) * (wx.stop - wx.start)
    if px > FINE_MAX_FRACTION * H * W:
        return None
    return wgt, plan


def fine_blend(out: np.ndarray, groups: dict, predict, wgt: np.ndarray, plan: list, f: int) -> int:
    """``out`` (H x W x 3, the upsampled prediction) with the full-resolution prediction blended in where ``wgt``
    (fine_plan) says, in place: ``predict(window groups)`` -> the window's prediction. Returns the pixels run."""
    H, W = out.shape[:2]
    guide = {"depth": np.zeros((H, W), np.float32)}  # upsample_light reads the output size from it
    w_hi = upsample_light(wgt, {}, guide, method="bilinear", factor=f)[..., 0]
    up = lambda m: np.repeat(np.repeat(m, f, 0), f, 1)[:H, :W]  # noqa: E731  (blocks -> their pixels)
    w_hi[up(wgt >= 1.0)] = 1.0  # the ring's own pixels: all fine; the fade's: bilinear; outside the boxes: none
    w_hi[up(wgt <= 0.0)] = 0.0
    run = 0
    for wy, wx, cy, cx in plan:
        p = predict({k: v[wy, wx] for k, v in groups.items()})
        run += p.shape[0] * p.shape[1]
        core = p[cy.start - wy.start:cy.stop - wy.start, cx.start - wx.start:cx.stop - wx.start, :3]
        w = w_hi[cy, cx, None]
        o = out[cy, cx, :3]
        o += w * (core - o)
    return run
