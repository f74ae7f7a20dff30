"""Near emitters, the network at the output resolution (bpy-free, numpy only; docs/working_res.md).

Why: beside an emitter tens of times brighter than its surround, the network run at 1/4 of 960x540 predicts far
more light than the surround gets in the blocks next to the emitter (the Cornell box's ceiling round its panel:
mean error +0.21 within 4 px of it and +0.16 at 5-8 px, where the reference is 0.17 and 0.12; at full resolution
+0.04 and +0.03; docs/working_res.md), and no upsample can take that back (nor
does 1/2: the whole frame at 1/2 without this pass scored 26.02 dB against full resolution's 26.39).

So near emitters the image takes the network's prediction at full resolution, run on crops of the full-resolution
groups (each crop its box plus the network's tile overlap of context) with the working resolution's whole-image
statistics: all of it on the emitter, falling smoothly to none at ``FINE_REACH`` blocks from its outline. Where the
two predictions differ (the living room's lamp, docs/working_res.md) a seam along the blocks showed as steps, and a
short full-resolution ring with a short fade as a dark outline; the long smooth fall shows neither. Used by
``workres.WorkingResolution`` (step 5).
"""
from __future__ import annotations

import numpy as np

from .workres import _blocks, _pad_mult

# near emitters the network runs at the output resolution (``fine_plan``, docs/working_res.md)
FINE_EMISSION = 0.01  # a pixel whose emission (max channel) is above this is an emitter (normalize's "glow" rule)
FINE_REACH = 6  # working-resolution blocks from an emitter pixel over which the full-resolution share falls 1 -> 0
FINE_MAX_SHARE = 1.0  # the fine windows may cover at most this many times the working resolution's pixels (the
#                       fine pass then costs at most what the network costs there), else none is run


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


def chebyshev_distance(hot: np.ndarray, cap: int) -> np.ndarray:
    """Per pixel, the Chebyshev distance (pixels) to the nearest True pixel of ``hot``, at most ``cap``."""
    d = np.full(hot.shape, cap, np.float32)
    m = hot.copy()
    d[m] = 0
    for k in range(1, cap):
        g = _chebyshev_grow(m)
        d[g & ~m] = k
        m = g
    return d


def fine_weight(hot: np.ndarray, f: int) -> np.ndarray:
    """Per pixel, the share of the full-resolution prediction: 1 on an emitter pixel of ``hot``, falling as a
    smooth step of the (Chebyshev) distance to 0 at ``FINE_REACH`` blocks (``f`` pixels each): the seam follows
    the emitter's outline, not the blocks'."""
    reach = FINE_REACH * f
    t = 1 - chebyshev_distance(hot, reach) / np.float32(reach)
    return (t * t * (3 - 2 * t)).astype(np.float32)


def fine_plan(emission: np.ndarray, f: int, overlap: int, multiple: int = 1) -> tuple[np.ndarray, list] | None:
    """Where the network runs at the output resolution: every pixel within ``FINE_REACH`` blocks of an emitter
    pixel (``FINE_EMISSION``; module doc: why).

    Returns (H x W bool: the emitter pixels, [(window rows, window cols, core rows, core cols)]: each core a box
    of blocks holding such pixels (an XY cut of the blocks near emitters, so apart emitters get their own crops),
    each window its core plus ``overlap`` pixels of context on every side (at least the reach, so that the window
    holds every emitter pixel near its core), clipped to the image, starting on a multiple of ``multiple``), or
    None where there is no emitter or the windows would cover more than ``FINE_MAX_SHARE`` times the pixels of the
    working resolution."""
    e = np.asarray(emission, np.float32)
    e = e.max(-1) if e.ndim == 3 else e
    H, W = e.shape
    hot = e > FINE_EMISSION
    if not hot.any():
        return None
    reach = FINE_REACH
    near = _blocks(_pad_mult(hot, f), f).any(-1)
    for _ in range(reach):
        near = _chebyshev_grow(near)
    ctx = max(overlap, reach * f)
    plan, px = [], 0
    for y0, y1, x0, x1 in boxes(near):
        cy, cx = slice(y0 * f, min(H, y1 * f)), slice(x0 * f, min(W, x1 * f))
        wy0, wx0 = (max(0, c.start - ctx) // multiple * multiple for c in (cy, cx))
        wy, wx = slice(wy0, min(H, cy.stop + ctx)), slice(wx0, min(W, cx.stop + ctx))
        plan.append((wy, wx, cy, cx))
        px += (wy.stop - wy.start) * (wx.stop - wx.start)
    if px > FINE_MAX_SHARE * near.size:
        return None
    return hot, plan


def fine_blend(out: np.ndarray, groups: dict, predict, hot: np.ndarray, plan: list, f: int) -> int:
    """``out`` (H x W x 3, the upsampled prediction) with the full-resolution prediction blended in by
    ``fine_weight``, in place, over each core of ``plan`` (fine_plan): ``predict(window groups)`` -> the window's
    prediction. Returns the pixels the network ran on."""
    run = 0
    for wy, wx, cy, cx in plan:
        p = predict({k: v[wy, wx] for k, v in groups.items()})
        run += p.shape[0] * p.shape[1]
        core = (slice(cy.start - wy.start, cy.stop - wy.start), slice(cx.start - wx.start, cx.stop - wx.start))
        w = fine_weight(hot[wy, wx], f)[core][..., None]
        o = out[cy, cx, :3]
        o += w * (p[core][..., :3] - o)
    return run
