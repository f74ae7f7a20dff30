"""Prediction at a working resolution (bpy-free, numpy only: the torch and the ONNX backends share it).

The network runs on a G-buffer reduced by an integer factor ``f``; what it predicts comes back to
the output resolution as *diffuse light* guided by the full-resolution G-buffer:

1. ``reduce_groups(groups, f)``: every group is reduced to ceil(H/f) x ceil(W/f).
   - colour, light and unit groups (albedo, direct, world, emission, ao, ...) are box-averaged over each
     f x f block (partial blocks at the right/bottom border average only their real pixels): the mean
     reflectance and the mean light of the block, which is what the block's pixels integrate to.
   - depth and normal are NOT averaged: averaging across a silhouette makes a depth between the two
     surfaces and a short normal that belongs to neither. Each block takes depth AND normal from one real
     pixel, the one whose depth is nearest the block's median depth (the surface that covers most of the
     block: for a block half sky, half wall, whichever holds the majority; ties: the first in row order).
   - the derived whole-image statistics (``scene``, ``glow``) are NOT stored groups: the predictor derives
     them from the reduced groups (normalize.derived). They are means over the geometry pixels of
     log1p(albedo x direct), albedo and the geometry fraction, so they move only by the box average's
     effect on log1p (Jensen) and on the edge pixels: measured in docs/working_res.md.
2. The model predicts at the working resolution (tiled there, exactly as at any size: ``Predictor.predict``).
3. ``upsample_part``: the predicted diffuse part is divided by the reduced albedo (light = part / albedo; a
   colour channel with albedo ~0 takes the grey estimate sum(part) / sum(albedo)), the reduced direct light
   (soft when given) is subtracted with ``residual`` (off by default, docs/working_res.md), and the rest - the indirect light and the network's correction, smooth -
   is brought back by ``upsample_light``, a joint bilateral upsample (Kopf et al. 2007) guided by the
   full-resolution depth and normals: each output pixel averages the 3 x 3 working-resolution samples
   around its block with weights spatial x exp(-(dlog z / sigma_z)^2 - (1 - n.n') / sigma_n) x confidence,
   the confidence being the sample's mean albedo: samples where nothing was hit or the albedo is black
   (albedo 0) carry no weight instead of a made-up light of 0. A small floor on the range weight keeps an
   isolated thin object at the spatial average. With ``residual`` the full-resolution direct light is added back, so hard
   and soft shadow edges stay as sharp as the passes'.
4. ... x the full-resolution albedo: the diffuse part at the output size, whose edges are the G-buffer's own
   (an anti-aliased edge pixel's albedo is coverage x colour, so a half-covered sky-edge pixel gets half the
   surface's diffuse light, never a dark rim). compose.py then adds EEVEE's ``rest`` as at full resolution.
5. Near emitters (fine.py): the network's prediction at the output resolution, run on crops of the
   full-resolution groups with the working resolution's whole-image statistics (``normalize.image_stats``), all of
   it on an emitter, falling smoothly to none at six blocks from it; skipped where the crops would cover more
   pixels than the working resolution has (``fine.FINE_MAX_SHARE``).
Over 400 lines by a few: reduce, upsample and the wrapper are one algorithm with one set of conventions.
Vectorised numpy: the f x f sub-block positions are independent slices, run on ``default_threads()``
threads (numpy releases the GIL). Measured in docs/working_res.md.
"""
from __future__ import annotations

import math
import re

import numpy as np

from .. import channels as ch
from ..errors import UserError

FULL = "full"
AUTO = "auto"
# "auto" (docs/working_res.md): full resolution below AUTO_MIN_WIDTH; from there a one-render model (the
# frame that must cost no more than EEVEE's GI) at 1/AUTO_FACTOR, any other model at the largest factor that keeps
# the working image AUTO_WORK_WIDTH wide (1/2 at 960, 1/4 at 1920): the default model at 1/4 of 960x540 lost 0.47 dB
# to full resolution on the artist exterior, 0.14 at 1/2 and 0.23 at 1/4 of 1920x1080
AUTO_MIN_WIDTH = 960
AUTO_FACTOR = 4
AUTO_WORK_WIDTH = 480
SIGMA_Z = 0.05  # relative depth difference (log z) of the range kernel
SIGMA_N = 0.1  # 1 - cos(angle) of the normal range kernel (0.1: ~25 degrees)
SIGMA_S = 0.75  # spatial Gaussian, in working-resolution pixels
RANGE_FLOOR = 1e-3  # range weights never go below this (isolated thin objects fall back to the spatial mean)
EPS = 1e-4


# --- the setting ---------------------------------------------------------------------------------------

def parse_setting(text) -> str | int | tuple[int, int]:
    """"full" | "auto" | "Nx" (predict at 1/N of the output size per axis, N >= 1) | "WxH" (at most this size).
    Returns "full", "auto", an int factor, or (w, h)."""
    s = str(text).strip().lower()
    if s in (FULL, AUTO):
        return s
    m = re.fullmatch(r"(\d+)x", s) or re.fullmatch(r"1/(\d+)", s)
    if m:
        n = int(m.group(1))
        if not 1 <= n <= 64:
            raise UserError(f"working resolution {text!r}: the factor must be 1..64")
        return FULL if n == 1 else n
    m = re.fullmatch(r"(\d+)x(\d+)", s)
    if m and int(m.group(1)) > 0 and int(m.group(2)) > 0:
        return int(m.group(1)), int(m.group(2))
    raise UserError(f"working resolution {text!r}: expected 'full', 'auto', a factor like '4x' (1/4 of the output "
                    f"size per axis) or a size like '480x270'")


def factor_for(setting, width: int, height: int, one_render: bool = False) -> int:
    """The integer reduction factor of ``setting`` (parsed or text) for an output of ``width`` x ``height``.
    A size WxH gives the smallest factor whose working size fits in it. ``one_render``: "auto" for a one-render
    model (``channels.one_render``)."""
    s = parse_setting(setting) if isinstance(setting, str) else setting
    if s == FULL:
        return 1
    if s == AUTO:
        if width < AUTO_MIN_WIDTH:
            return 1
        return AUTO_FACTOR if one_render else max(1, width // AUTO_WORK_WIDTH)
    if isinstance(s, int):
        return max(1, s)
    w, h = s
    return max(1, math.ceil(width / w), math.ceil(height / h))


def working_size(width: int, height: int, factor: int) -> tuple[int, int]:
    return -(-width // factor), -(-height // factor)


# --- reduce ----------------------------------------------------------------------------------------------

def _pad_mult(a: np.ndarray, f: int, mode="edge") -> np.ndarray:
    ph, pw = (-a.shape[0]) % f, (-a.shape[1]) % f
    if not (ph or pw):
        return a
    pads = ((0, ph), (0, pw)) + ((0, 0),) * (a.ndim - 2)
    return np.pad(a, pads, mode="constant") if mode == "zero" else np.pad(a, pads, mode="edge")


def _block_sum(a: np.ndarray, f: int) -> np.ndarray:
    """Hp x Wp x C (multiples of f) -> h x w x C block sums: the f rows of each block added in order, then the f
    columns, as float32 adds of whole slices (2.5x faster than ``sum(axis=...)`` over the short block axis,
    which numpy runs as a strided inner loop; the same additions in the same order, so the same bits)."""
    Hp, Wp, C = a.shape
    h, w = Hp // f, Wp // f

    def add_middle(v):  # n x f x m -> n x m: the f slices added in order
        out = v[:, 0].copy()
        for k in range(1, v.shape[1]):
            out += v[:, k]
        return out

    rows = add_middle(np.asarray(a, np.float32).reshape(h, f, Wp * C))
    return add_middle(rows.reshape(h * w, f, C)).reshape(h, w, C)


def box_reduce(a: np.ndarray, f: int) -> np.ndarray:
    """Block means (partial border blocks: the mean of their real pixels). HxW(xC) -> h x w (x C) float32."""
    a = np.asarray(a, np.float32)
    a3 = a[..., None] if a.ndim == 2 else a
    H, W, _ = a3.shape
    s = _block_sum(_pad_mult(a3, f, "zero"), f)
    if H % f or W % f:
        s /= _block_sum(_pad_mult(np.ones((H, W, 1), np.float32), f, "zero"), f)
    else:
        s *= np.float32(1.0 / (f * f))
    return s[..., 0] if a.ndim == 2 else s


def _blocks(a: np.ndarray, f: int) -> np.ndarray:
    """Hp x Wp (multiples of f) -> h x w x f*f: each block's samples, row-major."""
    h, w = a.shape[0] // f, a.shape[1] // f
    return a.reshape(h, f, w, f).transpose(0, 2, 1, 3).reshape(h, w, f * f)


def representative_index(depth: np.ndarray, f: int) -> np.ndarray:
    """h x w int: per block, the index (0..f*f-1, row-major in the block) of the sample whose depth is nearest
    the block's median depth. Border blocks are padded with copies of the edge pixels (real samples)."""
    z = np.asarray(depth, np.float32)
    z = np.nan_to_num(z[..., 0] if z.ndim == 3 else z, nan=np.float32(3e38), posinf=np.float32(3e38))
    zb = _blocks(_pad_mult(z, f), f)
    # np.median's value (the middle sample, or the float32 mean of the two middle ones) from a full sort of the
    # f*f samples, which numpy does 6x faster than median's partition over a short last axis
    s = np.sort(zb, axis=-1)
    k = zb.shape[-1]
    with np.errstate(over="ignore"):  # two "nothing hit" samples (3e38) sum to inf, as in np.median
        med = s[..., k // 2:k // 2 + 1] if k % 2 else (s[..., k // 2 - 1:k // 2] + s[..., k // 2:k // 2 + 1]) / np.float32(2)
    return np.argmin(np.abs(zb - med), axis=-1)


def pick(a: np.ndarray, f: int, idx: np.ndarray) -> np.ndarray:
    """The samples ``idx`` (representative_index) of each block of ``a`` (HxW or HxWxC)."""
    a = np.asarray(a, np.float32)
    a3 = _pad_mult(a[..., None] if a.ndim == 2 else a, f)
    h, w = idx.shape
    by, bx = np.divmod(idx, f)
    rows = (np.arange(h)[:, None] * f + by)
    cols = (np.arange(w)[None, :] * f + bx)
    out = a3[rows, cols]
    return out[..., 0] if a.ndim == 2 else out


def reduce_groups(groups: dict, factor: int | None = None, size: tuple[int, int] | None = None,
                  threads: int | None = None) -> dict:
    """The groups at the working resolution: ``factor`` (int >= 1) or ``size`` (w, h: the smallest factor that
    fits). Depth and normal come from one representative pixel per block; everything else is box-averaged.
    ``threads``: groups reduced in parallel (numpy releases the GIL; None: default_threads())."""
    H, W = next(iter(groups.values())).shape[:2]
    f = int(factor) if factor is not None else factor_for(tuple(size), W, H)
    if f < 1:
        raise UserError(f"working resolution factor {factor}: must be >= 1")
    if f == 1:
        return dict(groups)
    idx = representative_index(groups["depth"], f) if "depth" in groups else None

    def one(name):
        kind = ch.GROUPS[name].kind if name in ch.GROUPS else "light"
        return pick(groups[name], f, idx) if kind in ("depth", "normal") and idx is not None else box_reduce(groups[name], f)

    names = list(groups)
    n = max(1, min(threads or default_threads(), len(names)))
    if n == 1:
        return {k: one(k) for k in names}
    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(n) as ex:
        return dict(zip(names, ex.map(one, names)))


# --- upsample --------------------------------------------------------------------------------------------

def _log_depth(z) -> np.ndarray:
    z = np.asarray(z, np.float32)
    z = z[..., 0] if z.ndim == 3 else z
    return np.log(np.clip(np.nan_to_num(z, nan=1e9, posinf=1e9), 1e-6, 1e9)).astype(np.float32)


def _phases(a: np.ndarray, f: int) -> np.ndarray:
    """Hp x Wp (x C) -> f x f x h x w (x C) contiguous: the high-res pixels of each sub-block position."""
    h, w = a.shape[0] // f, a.shape[1] // f
    r = a.reshape((h, f, w, f) + a.shape[2:])
    return np.ascontiguousarray(np.moveaxis(r, (1, 3), (0, 1)))


def _taps(f: int, taps: int, guided: bool):
    """Per sub-block position (py or px): [(low offset, spatial weight)] along one axis."""
    out = []
    for p in range(f):
        t = (p + 0.5) / f - 0.5  # position from the block centre, in low-res pixels
        if taps == 2:  # the two nearest low-res centres, bilinear (tent) weights
            o = -1 if t < 0 else 0
            out.append([(o, 1.0 - (t - o)), (o + 1, t - o)])
        else:
            out.append([(d, math.exp(-((t - d) ** 2) / (2 * SIGMA_S ** 2)) if guided else max(0.0, 1 - abs(t - d)))
                        for d in (-1, 0, 1)])
    return out


def upsample_light(light_lo: np.ndarray, guide_lo: dict, guide_hi: dict, weight_lo: np.ndarray | None = None,
                   method: str = "guided", sigma_z: float = SIGMA_Z, sigma_n: float = SIGMA_N,
                   taps: int = 3, factor: int | None = None, threads: int | None = None) -> np.ndarray:
    """h x w x C light -> H x W x C float32, H x W = guide_hi's size (h = ceil(H/f), w = ceil(W/f)).

    ``guide_lo`` / ``guide_hi``: {"depth": ..(x1), "normal": ..x3} at the two resolutions (the low one as
    reduce_groups makes it). ``weight_lo``: h x w (x1) confidence of each low sample (None: 1). ``method``:
    "guided" (joint bilateral: spatial x depth x normal weights, module doc) or "bilinear" (spatial tent weights
    only). ``taps``: 3 (the 3 x 3 low samples around the pixel's block) or 2 (the 2 x 2 nearest centres).
    ``factor``: the reduction factor (None: inferred from the two sizes). ``threads``: worker threads over the
    f x f sub-block positions (None: up to 4, the CPUs this process may use)."""
    if method not in ("guided", "bilinear"):
        raise UserError(f"upsample method {method!r}: expected 'guided' or 'bilinear'")
    L = np.asarray(light_lo, np.float32)
    L = L[..., None] if L.ndim == 2 else L
    h, w, C = L.shape
    zh = guide_hi["depth"]
    H, W = zh.shape[:2]
    f = int(factor) if factor else max(1, -(-H // h), -(-W // w))
    if -(-H // f) != h or -(-W // f) != w:
        raise UserError(f"upsample: {w}x{h} is not the working size of {W}x{H} at any integer factor")
    c = np.ones((h, w), np.float32) if weight_lo is None else np.asarray(weight_lo, np.float32).reshape(h, w)
    pad = lambda a: np.pad(a, ((1, 1), (1, 1)) + ((0, 0),) * (a.ndim - 2), mode="edge")  # noqa: E731
    Lc = np.pad(np.moveaxis(L, -1, 0), ((0, 0), (1, 1), (1, 1)), mode="edge")  # C x h+2 x w+2
    cp = pad(c)
    guided = method == "guided"
    if guided:
        iz = np.float32(1.0 / sigma_z)
        zlo = pad(_log_depth(guide_lo["depth"]) * iz)
        nlo = np.moveaxis(pad(np.asarray(guide_lo["normal"], np.float32)), -1, 0) * np.float32(1.0 / sigma_n)
        zhi = _phases(_pad_mult(_log_depth(zh) * iz, f), f)
        nhi = np.ascontiguousarray(np.moveaxis(_phases(_pad_mult(np.asarray(guide_hi["normal"], np.float32), f), f), -1, 2))  # f f 3 h w
    tx = _taps(f, taps, guided)
    Hp, Wp = h * f, w * f
    res = np.empty((Hp, Wp, C), np.float32)
    view = res.reshape(h, f, w, f, C)

    def phases(todo):
        acc = np.empty((C, h, w), np.float32)
        den, wgt, prod = (np.empty((h, w), np.float32) for _ in range(3))
        if guided:
            e, tmp = np.empty((h, w), np.float32), np.empty((h, w), np.float32)
        for py, px in todo:
            den.fill(0.0)
            acc.fill(0.0)
            for dy, sy in tx[py]:
                for dx, sx in tx[px]:
                    s = np.float32(sy * sx)
                    if s <= 0:
                        continue
                    sl = (slice(1 + dy, 1 + dy + h), slice(1 + dx, 1 + dx + w))
                    if guided:  # exp(-(dz^2 + (1 - n.n') / sigma_n)), z and n' prescaled
                        np.subtract(zhi[py, px], zlo[sl], out=e)
                        np.multiply(e, e, out=e)
                        for k in range(3):
                            np.multiply(nhi[py, px, k], nlo[k][sl], out=tmp)
                            np.subtract(e, tmp, out=e)
                        np.subtract(np.float32(-1.0 / sigma_n), e, out=e)
                        np.exp(e, out=wgt)
                        wgt += np.float32(RANGE_FLOOR)
                        wgt *= s
                        wgt *= cp[sl]
                    else:
                        np.multiply(cp[sl], s, out=wgt)
                    den += wgt
                    for k in range(C):
                        np.multiply(wgt, Lc[k][sl], out=prod)
                        acc[k] += prod
            np.maximum(den, np.float32(1e-30), out=den)
            for k in range(C):
                np.divide(acc[k], den, out=view[:, py, :, px, k])

    todo = [(py, px) for py in range(f) for px in range(f)]
    n = max(1, min(threads or default_threads(), len(todo)))
    if n == 1:
        phases(todo)
    else:  # numpy's ufuncs release the GIL: the phases run in parallel
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(n) as ex:
            list(ex.map(phases, [todo[i::n] for i in range(n)]))
    return res[:H, :W] if (Hp, Wp) != (H, W) else res


def default_threads() -> int:
    import os
    return max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1))


def _finite_light(a) -> np.ndarray:
    """float32 light >= 0; non-finite values (rare: a fast sum check first) -> 0."""
    a = np.asarray(a, np.float32)[..., :3]
    with np.errstate(invalid="ignore", over="ignore"):
        ok = np.isfinite(a.sum(dtype=np.float32))
    if not ok:
        a = np.where(np.isfinite(a), a, np.float32(0.0))
    return np.maximum(a, np.float32(0.0))


def diffuse_light(part_lo: np.ndarray, albedo_lo: np.ndarray, signed: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(light, confidence) at the working resolution: light = part / albedo per channel where that channel's
    albedo > EPS, else the grey estimate sum(part) / sum(albedo); confidence = the mean albedo (0 where
    nothing was hit or the albedo is black: such samples take no part in the upsample). ``signed``: the part may be
    negative (a ref_combined model's, added to EEVEE's image), else it is clamped at 0 first."""
    a = np.clip(np.asarray(albedo_lo, np.float32)[..., :3], 0, 1)
    p = np.nan_to_num(np.asarray(part_lo, np.float32)[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
    if not signed:
        p = np.maximum(p, 0)
    grey = p.sum(-1, keepdims=True) / np.maximum(a.sum(-1, keepdims=True), EPS)
    light = np.where(a > EPS, p / np.maximum(a, EPS), grey).astype(np.float32)
    conf = a.mean(-1)
    return light, np.where(conf > EPS, conf, 0.0).astype(np.float32)


def base_light(groups: dict) -> np.ndarray | None:
    """The full-resolution light the upsample keeps sharp: the soft direct light when given, else the hard one."""
    for g in ("direct_soft", "direct"):
        if g in groups:
            return _finite_light(groups[g])
    return None


def upsample_part(part_lo: np.ndarray, lo: dict, hi: dict, method: str = "guided", residual: bool = False,
                  signed: bool = False, **kw) -> np.ndarray:
    """A diffuse part predicted at the working resolution -> the diffuse part at the output resolution:
    light = part / albedo (low res); with ``residual`` the direct light (``base_light``) is taken out before
    the upsample and its full-resolution version put back after (its shadow edges stay sharp); x the
    full-resolution albedo. ``signed``: a ref_combined model's part (added to EEVEE's GI-off Combined image, whose
    full-resolution edges and shadows stay as rendered): may be negative, never clamped."""
    light, conf = diffuse_light(part_lo, lo["albedo"], signed=signed)
    base_lo = base_light(lo) if residual else None
    if base_lo is not None:
        light -= base_lo
    H, W = np.shape(hi["albedo"])[:2]
    kw.setdefault("factor", max(-(-H // light.shape[0]), -(-W // light.shape[1])))
    up = upsample_light(light, lo, hi, weight_lo=conf, method=method, **kw)
    if base_lo is not None:
        up += base_light(hi)
    up *= np.clip(_finite_light(hi["albedo"]), 0, 1)
    return up if signed else np.maximum(up, np.float32(0.0), out=up)


# --- the wrapper ----------------------------------------------------------------------------------------

class WorkingResolution:
    """Any predictor (``.predict(groups, tile=-1)``, ``.target``, ``.spec``, ``.required``) run at a working
    resolution. ``setting``: "full", "auto", "Nx", "WxH" or an int factor (parse_setting). ``method``:
    "guided" or "bilinear"; ``residual``: keep the full-resolution direct light (upsample_part; off by default:
    +0.04-0.05 dB but the 4-sample soft direct pass's grain and the hard pass's steps come back, and SSIM drops,
    docs/working_res.md); ``threads``: the upsample's (upsample_light); ``fine``: the full-resolution prediction
    near emitters (step 5; a model's predictor only, where the groups hold ``emission``). After ``predict``:
    ``last_factor``, ``last_seconds`` (reduce, network, upsample, fine) and ``last_fine_pixels`` (the pixels the
    network ran on at full resolution). Everything else (``spec``, ``required``, ``last_repaired``, ...) is the
    inner predictor's. A whole-image (``ref``) model's prediction is upsampled as is (confidence: geometry)."""

    def __init__(self, predictor, setting="auto", method: str = "guided", residual: bool = False,
                 threads: int | None = None, fine: bool = True):
        if method not in ("guided", "bilinear"):
            raise UserError(f"upsample method {method!r}: expected 'guided' or 'bilinear'")
        self.inner = predictor
        self.setting = parse_setting(setting) if isinstance(setting, str) else setting
        self.method = method
        self.residual = residual
        self.threads = threads
        self.fine = fine
        self.last_fine_pixels = 0
        self.last_factor = 1
        self.last_seconds: dict = {}

    def __getattr__(self, name):  # spec, required, target, path, last_repaired, receptive_field, ...
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    @property
    def inputs(self):
        return getattr(self.inner, "inputs", self.inner.spec)

    def factor(self, width: int, height: int) -> int:
        # a boxmlp network (compositor nodes, docs/compiled.md) costs little at full resolution: "auto" is full there
        if self.setting == AUTO and (getattr(self.inner, "arch", None) or {}).get("backbone") == "boxmlp":
            return 1
        return factor_for(self.setting, width, height, ch.one_render(tuple(self.inner.spec)))

    def predict(self, groups: dict, tile: int | None = -1) -> np.ndarray:
        import time
        H, W = next(iter(groups.values())).shape[:2]
        f = self.last_factor = self.factor(W, H)
        if f == 1:
            return self.inner.predict(groups, tile=tile)
        for g in ("depth", "normal", "albedo"):
            if g not in groups:
                raise UserError(f"working resolution {f}x needs the {g} group to reduce and upsample")
        t0 = time.perf_counter()
        need = set(getattr(self.inner, "required", groups)) | {"depth", "normal", "albedo", "direct_soft", "direct"}
        lo = reduce_groups({k: v for k, v in groups.items() if k in need}, f, threads=self.threads)
        t1 = time.perf_counter()
        part = self.inner.predict(lo, tile=tile)
        t2 = time.perf_counter()
        fine = None  # a model's predictor (contract.ContractPredictor: crops with the whole image's statistics)
        if self.fine and "emission" in groups and hasattr(self.inner, "overlap"):
            from .fine import fine_plan
            fine = fine_plan(groups["emission"], f, self.inner.overlap, getattr(self.inner, "multiple", 1))
        target = getattr(self.inner, "target", ch.DIFFUSE_TARGET)
        signed = ch.signed_part(target)
        if ch.adds_part(target):
            out = upsample_part(part, lo, groups, method=self.method, residual=self.residual and not signed,
                                factor=f, threads=self.threads, signed=signed)
        else:
            from ..images import geometry_mask
            conf = geometry_mask(lo["depth"], lo["normal"]).astype(np.float32)[..., None]
            out = upsample_light(part, lo, groups, weight_lo=conf, method=self.method, factor=f,
                                 threads=self.threads)
        t3 = time.perf_counter()
        self.last_fine_pixels = 0
        if fine is not None:
            from .fine import fine_blend
            stats = self.inner.last_stats  # the whole-image values the low-res network's input used
            self.last_fine_pixels = fine_blend(out, {k: v for k, v in groups.items() if k in need},
                                               lambda g: self.inner.predict(g, tile=tile, stats=stats), *fine, f)
        self.last_seconds = dict(reduce=t1 - t0, network=t2 - t1, upsample=t3 - t2, fine=time.perf_counter() - t3)
        return out if signed else np.maximum(out, 0.0)
