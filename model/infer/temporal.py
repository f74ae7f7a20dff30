"""Temporal mode (bpy-free, numpy): reproject earlier frames with EEVEE's motion vectors, blend them into the
current prediction, and measure the flicker that is left.

**Blender 5.0's Vector pass (EEVEE), measured** (tests/blender/test_temporal.py
checks it): 4 channels X, Y, Z, W in PIXELS of the render, x to the right, y UP (the image's bottom-up
convention; our arrays are top row first, so a row offset is -Y).
- (X, Y) = position of the pixel's surface point in the PREVIOUS frame minus its position now;
- (Z, W) = position now minus its position in the NEXT frame (so -(Z, W) points to the next frame).
A camera moving +1 m along its x axis under an 8 m orthographic view 64 px wide gave X = +7.99 (content moves
8 px left; the point was 8 px to the right a frame earlier); a next step of +3 m gave Z = +23.98. A still
pixel has X = Y = 0 exactly. The values hold half-float precision, like EEVEE's other passes.

So frame t's pixel (row i, column j) was at (i - Y, j + X) in frame t-1 (array coordinates, pixel centres at
integers): ``prev_coords``.

**The blend** (``blend``): of the predicted diffuse LIGHT (the diffuse part divided by the albedo, before the
albedo multiply and before EEVEE's ``rest`` is added), at the output resolution (after the working-resolution
upsample: the history's guides are the full-resolution G-buffer, which is what tells surfaces apart). It is a
finite window, not a recursive filter: frame t's output is a function of the *stateless* predictions of frames
t, t-1, ..., t-k alone (each reprojected into t by chaining the vectors), so rendering out of order or resuming
gives the same frames. Where no history survives (first frame, camera cut, disocclusion, a still frame whose
history equals the present) the output is the stateless prediction bit for bit.

**The measure** (``warped_change``): see its docstring.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import metrics

# defaults of the window; chosen by benchmarks/temporal.py (docs/temporal.md)
WINDOW = 2  # k: frames t-1..t-k blended into t
HISTORY_WEIGHT = 0.6  # weight of each history frame against 1 for the current frame (times its confidence)
# a frame whose reprojected history covers less than this share of its geometry pixels counts as a cut
CUT_COVERAGE = 0.25
CLAMP = True  # clamp history to the present frame's 3 x 3 light range (blend)
EPS = 1e-4


@dataclass(frozen=True)
class Tolerances:
    """When a reprojected history sample is the same surface, under the same direct light, as the current pixel."""
    depth: float = 0.05  # |z_prev - z| / z at most (relative view depth; a camera dolly changes it a little)
    normal: float = 0.8  # cos(angle) of the camera-space normals at least (a camera turn rotates them)
    albedo: float = 0.1  # |albedo_prev - albedo| per channel at most
    # |direct_prev - direct| per channel at most this share of the larger of the two (+ LIGHT_FLOOR): the frame's
    # own rasterized direct light (history.DIRECT_LIGHT) changed there: a moving object's shadow, a lamp animated
    light: float = 0.25


LIGHT_FLOOR = 1e-3


def prev_coords(vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) float64 HxW: where each pixel of this frame was in the previous frame (array coordinates,
    top row first, pixel centres at integers), from EEVEE's Vector pass (HxWx4 or HxWx2: X, Y first)."""
    v = np.asarray(vector, np.float64)
    H, W = v.shape[:2]
    rows, cols = np.mgrid[0:H, 0:W].astype(np.float64)
    return rows - v[..., 1], cols + v[..., 0]


def _taps(rows: np.ndarray, cols: np.ndarray, H: int, W: int):
    """The 4 bilinear taps around (rows, cols): [(r, c, weight, in_frame)], indices clamped into the frame."""
    r0, c0 = np.floor(rows), np.floor(cols)
    fr, fc = rows - r0, cols - c0
    out = []
    for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, 1, (1 - fr) * fc), (1, 0, fr * (1 - fc)), (1, 1, fr * fc)):
        r, c = r0 + dr, c0 + dc
        inside = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        out.append((np.clip(r, 0, H - 1).astype(np.intp), np.clip(c, 0, W - 1).astype(np.intp), w, inside))
    return out


def _agree(prev: dict, cur: dict, tol: Tolerances) -> np.ndarray:
    """HxW bool: the previous frame's guides (gathered at the taps) agree with the current frame's (those both
    give)."""
    ok = None
    if "depth" in prev and "depth" in cur:
        z = cur["depth"][..., 0]
        ok = np.abs(prev["depth"][..., 0] - z) <= tol.depth * np.maximum(np.abs(z), EPS)
    if "normal" in prev and "normal" in cur:
        m = np.einsum("hwc,hwc->hw", prev["normal"][..., :3], cur["normal"][..., :3]) >= tol.normal
        ok = m if ok is None else ok & m
    if "albedo" in prev and "albedo" in cur:
        m = np.max(np.abs(prev["albedo"][..., :3] - cur["albedo"][..., :3]), -1) <= tol.albedo
        ok = m if ok is None else ok & m
    if "direct_light" in prev and "direct_light" in cur:
        a, b = prev["direct_light"][..., :3], cur["direct_light"][..., :3]
        m = np.all(np.abs(a - b) <= tol.light * np.maximum(np.abs(a), np.abs(b)) + LIGHT_FLOOR, -1)
        ok = m if ok is None else ok & m
    return ok


def sample(images: dict, rows, cols, cur: dict | None = None, tol: Tolerances = Tolerances()):
    """Bilinear samples of every HxWxC array of ``images`` at (rows, cols), using only the taps inside the frame
    whose guides (``images``' depth/normal/albedo) agree with ``cur``'s. Returns ({name: HxWxC float32}, weight
    HxW float32 in [0, 1]: the bilinear weight of the taps used; 0 = no valid history). Where the taps used
    carry all the weight (a still frame: one tap of weight 1) a sample is the tap's value exactly. float32;
    each tap gathers every array once (``np.take`` on the flattened image)."""
    H, W = next(iter(images.values())).shape[:2]
    h, w_ = rows.shape
    flat = {k: np.asarray(v, np.float32).reshape(H * W, -1) for k, v in images.items()}
    cur = {k: np.asarray(v, np.float32) for k, v in cur.items()} if cur is not None else None
    wsum = np.zeros((h, w_), np.float32)
    acc = {k: np.zeros((h, w_, a.shape[-1]), np.float32) for k, a in flat.items()}
    for r, c, wt, inside in _taps(rows, cols, H, W):
        idx = (r * W + c).ravel()
        got = {k: np.take(a, idx, axis=0).reshape(h, w_, -1) for k, a in flat.items()}
        ok = inside
        if cur is not None:
            agree = _agree(got, cur, tol)
            if agree is not None:
                ok = ok & agree
        wk = np.where(ok, wt, 0.0).astype(np.float32)
        wsum += wk
        for k in acc:
            acc[k] += wk[..., None] * got[k]
    has = wsum > 0
    safe = np.where(has, wsum, np.float32(1.0))[..., None]
    out = {k: np.where(has[..., None], v / safe, np.float32(0.0)).astype(np.float32) for k, v in acc.items()}
    return out, wsum


def reproject(prev_img: np.ndarray, vector: np.ndarray, prev_guides: dict | None = None,
              cur_guides: dict | None = None, tol: Tolerances = Tolerances()):
    """Backward warp of frame t-1's ``prev_img`` (HxWxC) into frame t with frame t's ``vector`` (bilinear).
    Returns (warped HxWxC float32, valid HxW float32 in [0, 1]): the share of the bilinear weight that falls on
    taps inside the frame whose depth, normal, albedo and direct light (``prev_guides`` of t-1 against ``cur_guides`` of t)
    agree: 0 out of frame and at disocclusions."""
    rows, cols = prev_coords(vector)
    imgs = {"img": prev_img} | {k: v for k, v in (prev_guides or {}).items()
                                if k in ("depth", "normal", "albedo", "direct_light")}
    out, w = sample(imgs, rows, cols, cur_guides if prev_guides else None, tol)
    return out["img"], w


def light_of(part: np.ndarray, albedo: np.ndarray, signed: bool = False) -> np.ndarray:
    """The diffuse light of a predicted diffuse part (part / albedo, grey where an albedo channel is ~0). ``signed``:
    a ref_combined model's part, the light it adds to EEVEE's image, kept negative where it takes light away."""
    from .workres import diffuse_light
    return diffuse_light(part, albedo, signed=signed)[0]


def reproject_window(history: list[dict], vector: np.ndarray, cur: dict, tol: Tolerances = Tolerances()):
    """Frames t-1, t-2, ... (``history``: dicts with light, depth, normal, albedo, vector) reprojected into t by
    chaining the vectors: t's vector maps into t-1, t-1's (sampled there) into t-2, and so on; a chain stops
    where a step lands on no valid tap. Returns [(light HxWx3, weight HxW)] in the order of ``history``."""
    rows, cols = prev_coords(vector)
    alive = np.ones(rows.shape, np.float32)
    out = []
    for h in history:
        imgs = {k: h[k] for k in ("light", "depth", "normal", "albedo", "vector", "direct_light") if k in h}
        s, w = sample(imgs, rows, cols, cur, tol)
        alive = alive * w
        out.append((s["light"], alive.copy()))
        if "vector" not in s:
            break
        rows, cols = rows - s["vector"][..., 1], cols + s["vector"][..., 0]
    return out


def neighbourhood(light: np.ndarray, radius: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) per channel over the (2 radius + 1)^2 pixels around each pixel (edge pixels repeated)."""
    H, W = light.shape[:2]
    p = np.pad(light, ((radius, radius), (radius, radius), (0, 0)), mode="edge")
    lo, hi = light.copy(), light.copy()
    for dy in range(2 * radius + 1):
        for dx in range(2 * radius + 1):
            v = p[dy:dy + H, dx:dx + W]
            np.minimum(lo, v, out=lo)
            np.maximum(hi, v, out=hi)
    return lo, hi


def blend(part: np.ndarray, albedo: np.ndarray, history: list[tuple[np.ndarray, np.ndarray]],
          weights=None, geometry: np.ndarray | None = None, cut_coverage: float = CUT_COVERAGE,
          clamp: bool = CLAMP, signed: bool = False) -> np.ndarray:
    """Frame t's diffuse part blended with the reprojected diffuse light of earlier frames.

    ``history``: [(light HxWx3, valid HxW in [0, 1])], t-1 first; ``weights``: each history frame's weight
    against 1 for the current frame (default ``HISTORY_WEIGHT`` each). Per pixel the light is
    (L_t + sum_j w_j v_j L_j) / (1 + sum_j w_j v_j), written as part_t + albedo_t x the change, so that a
    pixel with no valid history, or whose history equals L_t, is ``part`` bit for bit. When the first history
    frame covers less than ``cut_coverage`` of the ``geometry`` pixels (default: albedo > 0) the frame is
    taken as a cut and ``part`` comes back unchanged. With ``clamp`` each history light is first clamped to the
    range of the current light over the 3 x 3 pixels around (the neighbourhood clamp of temporal anti-aliasing):
    history can smooth what flickers within the present frame's local range, never drag a moved shadow or a
    change of light along (lag); a history equal to the present is inside that range and stays exact. ``signed``: a
    ref_combined model's part (the light it adds to EEVEE's image, negative where it takes light away: not clamped at
    0, which brightened the contact shadows an unshadowed emitter proxy leaves too bright)."""
    part = np.asarray(part, np.float32)
    if not history:
        return part
    albedo = np.clip(np.asarray(albedo, np.float32)[..., :3], 0, 1)
    geo = geometry if geometry is not None else albedo.max(-1) > EPS
    if not geo.any() or float(np.mean(history[0][1][geo] > 0.5)) < cut_coverage:
        return part
    ws = list(weights) if weights is not None else [HISTORY_WEIGHT] * len(history)
    cur32 = light_of(part, albedo, signed)
    lo, hi = neighbourhood(cur32) if clamp else (None, None)
    cur = cur32.astype(np.float64)
    num = np.zeros(cur.shape, np.float64)
    den = np.ones(cur.shape[:2], np.float64)
    for (light, valid), w in zip(history, ws):
        wv = w * np.asarray(valid, np.float64)
        light = np.clip(light, lo, hi) if clamp else light
        num += wv[..., None] * (np.asarray(light, np.float64) - cur)
        den += wv
    change = (num / den[..., None]).astype(np.float32)
    out = part + albedo * change
    if not signed:
        np.maximum(out, 0.0, out=out)
    used = den > 1.0
    return np.where(used[..., None], out, part)


def warped_change(frames: list, refs: list, vectors: list, masks: list | None = None) -> dict:
    """Item 1's measure: the flicker of a method against the converged reference, with motion taken out.

    For each t >= 1: m' = warp(m_{t-1}) and r' = warp(r_{t-1}) into t with frame t's ``vectors[t]``
    (``reproject``, no guides); e_t = mean over the valid pixels of
    | (T(m_t) - T(m')) - (T(r_t) - T(r')) |, T the Reinhard tonemap (metrics.tonemap) on all 3 channels. A valid
    pixel: ``masks[t]`` (HxW bool: e.g. the disocclusion mask of the reference's guides, True = keep) and the
    warp's weight 1 (all 4 taps inside the frame). The measure is the mean of e_t over t; ``per_step`` holds
    each e_t. A method that reproduces the reference's own change scores 0, whatever its per-frame error."""
    if not (len(frames) == len(refs) == len(vectors)) or len(frames) < 2:
        raise ValueError("warped_change needs at least two frames, and one reference and one vector per frame")
    steps, pixels = [], []
    for t in range(1, len(frames)):
        m0, m1 = metrics.tonemap(metrics.clean(frames[t - 1])), metrics.tonemap(metrics.clean(frames[t]))
        r0, r1 = metrics.tonemap(metrics.clean(refs[t - 1])), metrics.tonemap(metrics.clean(refs[t]))
        wm, v = reproject(m0, vectors[t])
        wr, _ = reproject(r0, vectors[t])
        keep = v >= 1.0 - 1e-6
        if masks is not None and masks[t] is not None:
            keep &= np.asarray(masks[t], bool)
        d = np.abs((m1 - wm) - (r1 - wr))[keep]
        steps.append(float(d.mean()) if d.size else float("nan"))
        pixels.append(int(keep.sum()))
    return dict(change=float(np.nanmean(steps)), per_step=steps, pixels=pixels)


def valid_mask(prev_guides: dict, cur_guides: dict, vector: np.ndarray, tol: Tolerances = Tolerances()) -> np.ndarray:
    """HxW bool: pixels of frame t whose whole bilinear footprint in t-1 is inside the frame and on the same
    surface (depth, normal, albedo agree): the pixels ``warped_change`` scores."""
    rows, cols = prev_coords(vector)
    _, w = sample({k: prev_guides[k] for k in ("depth", "normal", "albedo") if k in prev_guides}, rows, cols,
                  cur_guides, tol)
    return w >= 1.0 - 1e-6
