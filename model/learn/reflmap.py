"""Fit a shot's reflection map (model/infer/reflmap.py) to its views, and choose its weight (bpy-free).

``fit_reflmap(data_dir, cameras, train, val, seconds)`` needs views that hold EEVEE's rest and Glossy Color at the
node's settings (groups ``rest`` and ``gloss``: a shot fit bakes them, ``bake --rest-samples``) beside Cycles'
``ref`` and ``ref_diffuse``:

1. **Points.** Every pixel of the training views that ``reflmap.glossy_mask`` keeps gives a world position, a world
   reflection direction (``reflmap.reflected`` with the view's camera matrices, ``cameras.json``), the view's gloss,
   ``base`` = Cycles' diffuse part + EEVEE's rest (what the node shows there with a perfect diffuse prediction) and
   Cycles' image.
2. **Training.** An MLP (``HIDDEN`` wide, ``LAYERS`` hidden layers, ReLU) on ``lightmap.encode``'s features (position and reflected direction), Adam,
   batches of ``BATCH`` random points, the L1 distance between clamp(base + gloss x field, 0, 1) and clamp(Cycles,
   0, 1) (the [0, 1] range the PSNR scores: a highlight above 1 needs no exact value), the learning rate on a
   cosine over the time budget. Bounded by ``seconds``.
3. **The weight.** On the validation views, Cycles' diffuse part + EEVEE's rest + ``lam`` x the correction against
   Cycles' image, pooled PSNR over the geometry pixels, for each ``LAMBDAS``; the best is kept (0: the map is not
   used). The network's diffuse prediction does not enter: the map changes only the rest, which the node adds to
   every prediction alike.

``combined`` (a ref_combined model's map): such a model's image takes the map only where the albedo is
below the head's floor (``reflmap.combined_weight``: metal, mirrors); elsewhere its network learned Cycles'
reflections itself. Its points are then those pixels, their gloss x that weight, and its weight is chosen on the
image it makes (base + lam x weight x the correction), so a map that helps the metal is not refused for what it
would have done to a glossy floor the model never corrects with it.
"""
from __future__ import annotations

import time

import numpy as np
import torch

from .. import metrics
from ..dataset import exrio, folder
from ..errors import UserError
from ..infer import reflmap as rm
from . import lightmap as llm

HIDDEN = 128
LAYERS = 3
BATCH = 4096
LR = 2e-3
LAMBDAS = (0.0, 0.5, 0.75, 1.0)
MIN_POINTS = 200
NEED = ("normal", "depth", "gloss", "rest", "ref", "ref_diffuse")


def _read(data_dir, key, combined: bool = False):
    need = NEED + (("albedo",) if combined else ())
    return exrio.read_sample(folder.sample_path(data_dir, str(key)), need)  # UserError names a missing group


def _applied(g: dict, combined: bool) -> np.ndarray:
    """HxWx1 (or 1.0): the share of the correction the model's image takes at each pixel (module doc)."""
    return rm.combined_weight(g["albedo"]) if combined else np.float32(1.0)


def points(data_dir, cameras: dict, keys, combined: bool = False) -> dict[str, np.ndarray]:
    """{pos, dir, gloss, base, ref}: Nx3 each, of the views ``keys`` (module doc, step 1; ``combined``: only where a
    ref_combined model's image takes the map, gloss x that share)."""
    out = {k: [] for k in ("pos", "dir", "gloss", "base", "ref")}
    for k in keys:
        if str(k) not in cameras:
            raise UserError(f"{data_dir}: view {k} has no camera matrices in cameras.json")
        g = _read(data_dir, k, combined)
        c = cameras[str(k)]
        share = _applied(g, combined)
        ok = rm.glossy_mask(g)
        if combined:
            ok &= share[..., 0] > 0
        if not ok.any():
            continue
        pw, r = rm.reflected(g["depth"], g["normal"], c["M"], c["P"])
        base = g["ref_diffuse"][..., :3] + g["rest"][..., :3]
        vals = dict(pos=pw, dir=r, gloss=g["gloss"][..., :3] * share, base=base, ref=g["ref"][..., :3])
        ok &= np.all([np.isfinite(v).all(-1) for v in vals.values()], axis=0)
        for name, v in vals.items():
            out[name].append(np.asarray(v, np.float32)[ok])
    return {k: (np.concatenate(v) if v else np.zeros((0, 3), np.float32)) for k, v in out.items()}


def train_field(pts: dict, seconds: float, seed: int = 0, log=None, steps: int | None = None,
                nfreq_pos: int = rm.NFREQ_POS, nfreq_dir: int = rm.NFREQ_DIR) -> tuple[rm.ReflectionMap, dict]:
    """Train the MLP on ``points``' output for ``seconds`` (module doc, step 2), or ``steps`` steps when that comes
    first; returns (ReflectionMap with lam 0, stats)."""
    n = len(pts["pos"])
    if n < MIN_POINTS:
        raise UserError(f"reflection map: {n} glossy pixels in the training views (Glossy Color above "
                        f"{rm.GLOSS_MIN}), at least {MIN_POINTS} needed")
    torch.manual_seed(seed)
    lo, hi = pts["pos"].min(0), pts["pos"].max(0)
    net = llm._Field(lo, hi, nfreq_pos, HIDDEN, LAYERS, nfreq_dir=nfreq_dir)
    with torch.no_grad():  # start at "no correction": EEVEE's own rest
        net.layers[-1].weight.mul_(0.01)
        net.layers[-1].bias.zero_()
    T = {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in pts.items()}
    ref01 = torch.clamp(T["ref"], 0.0, 1.0)

    def loss_of(i):
        img = torch.clamp(T["base"][i] + T["gloss"][i] * net(T["pos"][i], T["dir"][i]), 0.0, 1.0)
        return (img - ref01[i]).abs().mean()
    step, run, secs = llm.train_steps(net, loss_of, n, seconds, steps, seed, log, "reflection map", LR, BATCH)
    weights = [(layer.weight.detach().numpy(), layer.bias.detach().numpy()) for layer in net.layers]
    base_loss = float((torch.clamp(T["base"], 0.0, 1.0) - ref01).abs().mean())
    stats = dict(points=int(n), steps=step, seconds=secs,
                 loss=float(np.mean(run[-200:])) if run else None, loss_without=base_loss, hidden=HIDDEN,
                 layers=LAYERS, nfreq_pos=nfreq_pos, nfreq_dir=nfreq_dir)
    return rm.ReflectionMap(weights, lo, hi, nfreq_pos, nfreq_dir, 0.0, meta=stats), stats


def choose_weight(field: rm.ReflectionMap, data_dir, cameras: dict, keys, combined: bool = False) -> tuple[float, dict]:
    """(lam, {lam: pooled PSNR}) on the validation views ``keys`` (module doc, step 3; ``combined``: the correction
    as a ref_combined model's image takes it)."""
    from ..images import geometry_mask
    pools = {lam: metrics.PooledPSNR() for lam in LAMBDAS}
    for k in keys:
        g = _read(data_dir, k, combined)
        c = cameras[str(k)]
        mask = geometry_mask(g["depth"], g["normal"])
        base = g["ref_diffuse"][..., :3] + g["rest"][..., :3]
        corr = field.correction(g, c["M"], c["P"], lam=1.0) * _applied(g, combined)
        for lam in LAMBDAS:
            pools[lam].add(np.maximum(base + lam * corr, 0.0)[mask], g["ref"][..., :3][mask])
    scores = {lam: pools[lam].value for lam in LAMBDAS}
    best = max(LAMBDAS, key=lambda lam: (scores[lam], lam))
    return best, scores


def fit_reflmap(data_dir, cameras: dict, train, val, seconds: float, seed: int = 0, log=None,
                steps: int | None = None, combined: bool = False) -> tuple[rm.ReflectionMap, dict]:
    """Points, training, weight (module doc; ``combined``: a ref_combined model's map). Returns (ReflectionMap with its
    lam, report dict)."""
    t0 = time.perf_counter()
    pts = points(data_dir, cameras, train, combined)
    field, stats = train_field(pts, max(seconds - (time.perf_counter() - t0), 1.0), seed=seed, log=log, steps=steps)
    lam, scores = choose_weight(field, data_dir, cameras, val, combined)
    field.lam = lam
    rep = dict(stats, lam=lam, val_psnr={str(k): round(v, 3) for k, v in scores.items()},
               seconds_total=time.perf_counter() - t0, combined=bool(combined))
    field.meta = rep
    if log:
        log(f"reflection map: {stats['points']} points, {stats['steps']} steps; val PSNR (Cycles' diffuse part + "
            "EEVEE's rest + weight x the map) " + ", ".join(f"{k:g}: {v:.2f}" for k, v in scores.items())
            + f"; weight {lam:g}")
    return field, rep
