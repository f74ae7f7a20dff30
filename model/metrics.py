"""Image metrics (numpy, bpy-free). Images are HxWx3 linear HDR RGB float arrays.

- ``psnr`` / ``PooledPSNR``: the seed's convention. Both images are clamped to [0, 1] in LINEAR RGB, and the
  squared error is pooled over all pixels and channels of all images before the log:
  PSNR = 10 log10(1 / MSE). Identical images give +inf.
- ``tonemap``: Reinhard per channel, t(x) = x / (1 + x) for x >= 0 (negative and NaN -> 0, +inf -> 1), and its
  inverse ``inverse_tonemap``: y / (1 - y). ``tm_psnr`` is the pooled PSNR of tonemapped images (peak 1).
  Unlike the seed's clamp, it also scores errors in lights brighter than 1.
- ``ssim``: scikit-image's structural_similarity on the clamped [0, 1] linear images (data_range 1, channel
  axis last, 7x7 uniform window, or the largest odd window that fits). Images under 3 pixels on a side
  have no SSIM window: they score 1 - mean absolute difference of the clamped images.
- ``flip``: mean HDR-FLIP (NVIDIA's flip-evaluator) of the linear HDR images; 0 = identical, higher = worse.
- ``score``: every metric of one image, over the geometry pixels when a mask is given: the one scoring of
  training's validation, the fit and the report (``PooledPSNR.add_score`` pools its squared errors).
"""
from __future__ import annotations

import math

import numpy as np


def _clamp01(a) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    return np.clip(np.nan_to_num(a, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)


def tonemap(x) -> np.ndarray:
    x = np.nan_to_num(np.asarray(x, dtype=np.float64), nan=0.0, posinf=np.inf, neginf=0.0)
    x = np.maximum(x, 0.0)
    with np.errstate(invalid="ignore"):
        y = np.where(np.isinf(x), 1.0, x / (1.0 + x))
    return y


def inverse_tonemap(y) -> np.ndarray:
    y = np.clip(np.asarray(y, dtype=np.float64), 0.0, 1.0)
    with np.errstate(divide="ignore"):
        return np.where(y >= 1.0, np.inf, y / np.maximum(1.0 - y, 1e-300))


def psnr_from_mse(mse: float, peak: float = 1.0) -> float:
    if mse <= 0:
        return math.inf
    return 10.0 * math.log10(peak * peak / mse)


class PooledPSNR:
    """Accumulates squared error over many images; ``value`` is the pooled PSNR (seed's convention, or after
    the tonemap with ``tonemapped=True``)."""

    def __init__(self, tonemapped: bool = False):
        self.tonemapped = tonemapped
        self.sse = 0.0
        self.n = 0

    def add_score(self, s: dict) -> None:
        """Pool the squared errors of a ``score`` result (its ``tm_sse`` when ``tonemapped``)."""
        self.sse += s["tm_sse" if self.tonemapped else "sse"]
        self.n += s["pixels"]

    def add(self, pred, ref) -> None:
        if np.shape(pred) != np.shape(ref):
            raise ValueError(f"shapes differ: {np.shape(pred)} vs {np.shape(ref)}")
        f = tonemap if self.tonemapped else _clamp01
        d = f(pred) - f(ref)
        self.sse += float(np.sum(d * d))
        self.n += d.size

    @property
    def mse(self) -> float:
        return self.sse / self.n if self.n else math.nan

    @property
    def value(self) -> float:
        return psnr_from_mse(self.mse) if self.n else math.nan


def psnr(pred, ref) -> float:
    """PSNR by the seed's convention for one image or a stack (pooled)."""
    p = PooledPSNR()
    p.add(pred, ref)
    return p.value


def tm_psnr(pred, ref) -> float:
    p = PooledPSNR(tonemapped=True)
    p.add(pred, ref)
    return p.value


def ssim(pred, ref) -> float:
    """SSIM on clamped linear [0,1] RGB (see module doc)."""
    from skimage.metrics import structural_similarity

    a, b = _clamp01(pred), _clamp01(ref)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: {a.shape} vs {b.shape}")
    side = min(a.shape[0], a.shape[1])
    if side < 3:
        return float(1.0 - np.mean(np.abs(a - b)))
    win = min(7, side if side % 2 else side - 1)
    return float(structural_similarity(a, b, data_range=1.0, channel_axis=-1, win_size=win))


def clean(a) -> np.ndarray:
    """Linear RGB for FLIP and the temporal error: the first 3 channels, NaN and negative -> 0, +Inf -> 65504."""
    a = np.nan_to_num(np.asarray(a, dtype=np.float32)[..., :3], nan=0.0, posinf=65504.0, neginf=0.0)
    return np.ascontiguousarray(np.maximum(a, 0.0))


def flip(pred, ref) -> float:
    """Mean HDR-FLIP error of linear HDR RGB ``pred`` against ``ref`` (flip-evaluator; 0 = identical).

    Negative and NaN values count as 0. A reference with no light at all (max 0) has no exposure range for
    HDR-FLIP: both images are then scored by LDR-FLIP after clamping to [0, 1]."""
    import flip_evaluator

    p, r = clean(pred), clean(ref)
    if p.shape != r.shape:
        raise ValueError(f"shapes differ: {p.shape} vs {r.shape}")
    if float(r.max(initial=0.0)) <= 0.0:
        _, mean, _ = flip_evaluator.evaluate(r.clip(0, 1), p.clip(0, 1), "LDR", inputsRGB=False, applyMagma=False)
    else:
        _, mean, _ = flip_evaluator.evaluate(r, p, "HDR", applyMagma=False)
    return float(mean)


def score(pred, ref, mask=None, with_ssim: bool = True, with_flip: bool = True) -> dict:
    """Every metric of one HxWx3 linear image against its reference: psnr, tm_psnr, ssim, flip, and the squared
    errors pooled PSNRs need (sse, tm_sse, mse, tm_mse over ``pixels`` values).

    ``mask`` (HxW bool, images.geometry_mask): the pixels scored. Where nothing was hit the world shows,
    which the G-buffer does not describe and the SSGI node composites from EEVEE; the PSNRs pool only the
    masked pixels, SSIM and FLIP see the reference pasted in elsewhere (as the node shows it). SSIM / FLIP are
    None when not asked for."""
    pred, ref = np.asarray(pred)[..., :3], np.asarray(ref)[..., :3]
    if mask is not None and not mask.all():
        pm, rm = pred[mask], ref[mask]
        pred = np.where(mask[..., None], pred, ref)
    else:
        pm, rm = pred, ref
    p, t = PooledPSNR(), PooledPSNR(tonemapped=True)
    if pm.size:
        p.add(pm, rm)
        t.add(pm, rm)
    return dict(psnr=p.value, tm_psnr=t.value, ssim=ssim(pred, ref) if with_ssim else None,
                flip=flip(pred, ref) if with_flip else None, sse=p.sse, tm_sse=t.sse, mse=p.mse, tm_mse=t.mse,
                pixels=int(p.n))
