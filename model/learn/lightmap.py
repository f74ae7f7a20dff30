"""Fit a shot's lightmap (model/infer/lightmap.py) to its views, and choose how much of it the node uses (bpy-free).

``fit_lightmap(data_dir, cameras, train, val, model, target, seconds)``:

1. **Points.** Every geometry pixel of the training views whose albedo exceeds ``lightmap.ALBEDO_MIN`` in every
   channel gives a world position and normal (``lightmap.world_points`` with the view's camera matrices, which the
   fit stores in ``cameras.json`` beside the views) and a diffuse light: the fit's target (Cycles' diffuse part, or
   for a one-render model the light it adds to EEVEE's GI-off image) divided by the albedo.
2. **Training.** An MLP (``HIDDEN`` wide, ``LAYERS`` hidden layers, ReLU) on ``lightmap.encode``'s features, Adam,
   batches of ``BATCH`` random points, the relative L1 loss |y' - y| / (1 + y), the learning rate on a cosine over
   the time budget. Bounded by ``seconds``; nothing else runs meanwhile.
   With known light (model/infer/lightmap.py ``known``), the target is the diffuse light minus the view's own
   direct light, and the loss divides by 1 + |y|.
3. **The blend weight.** On the validation views (held out from both the network and the lightmap), the fitted
   network's diffuse part (as the node predicts it) is blended with the lightmap at each weight of ``LAMBDAS``
   (``Lightmap.apply``: black albedo and the sky keep the network) and composed as the node composes;
   the weight with the best pooled PSNR against the views' references is kept (0: the lightmap is not used), or a
   higher one within ``TIE_DB`` of it.

Measured on the two benchmark shots in docs/fit.md.
"""
from __future__ import annotations

import math
import time

import numpy as np
import torch

from .. import channels as ch, metrics
from ..dataset import exrio, folder
from ..errors import UserError
from ..infer import lightmap as lm

HIDDEN = 128
LAYERS = 3
BATCH = 4096
LR = 2e-3
LAMBDAS = (0.0, 0.25, 0.5, 0.75, 1.0)
# a higher weight within this many dB of the best validation PSNR is preferred: the validation views share their
# frames with training views (jittered cameras), where the network is relatively better than on frames no view saw
# (docs/fit.md: on both shots' withheld frames the best weight was at or above the one validation
# chose, by up to 0.5)
TIE_DB = 0.1
MIN_POINTS = 1000


def view_target(groups: dict, target: str) -> np.ndarray:
    """The fit's target of a view (channels.TARGET_SOURCES: ref_combined = ref - eevee_combined, signed: what that
    model's prediction adds to EEVEE's GI-off image)."""
    if target == ch.COMBINED_TARGET:
        return groups["ref"][..., :3] - groups["eevee_combined"][..., :3]
    return groups[target][..., :3]


def points(data_dir, cameras: dict, keys, target: str, known=()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Nx3 positions, Nx3 normals, Nx3 diffuse light) of the views ``keys`` (module doc, step 1); with ``known``
    groups, the diffuse light minus their sum (signed: what a known-light field learns, lightmap.known_light)."""
    P_, N_, Y_ = [], [], []
    need = tuple(dict.fromkeys(("albedo", "normal", "depth") + ch.TARGET_SOURCES.get(target, (target,)) + tuple(known)))
    for k in keys:
        if str(k) not in cameras:
            raise UserError(f"{data_dir}: view {k} has no camera matrices in cameras.json")
        g = exrio.read_sample(folder.sample_path(data_dir, str(k)), need)
        c = cameras[str(k)]
        pw, nw = lm.world_points(g["depth"], g["normal"], c["M"], c["P"])
        alb = g["albedo"][..., :3]
        from ..images import geometry_mask
        ok = geometry_mask(g["depth"], g["normal"]) & (alb > lm.ALBEDO_MIN).all(-1)
        y = view_target(g, target) / np.maximum(alb, lm.ALBEDO_MIN)
        y = y - lm.known_light(g, known)
        ok &= np.isfinite(y).all(-1) & np.isfinite(pw).all(-1)
        P_.append(pw[ok]); N_.append(nw[ok]); Y_.append(y[ok].astype(np.float32))
    return np.concatenate(P_), np.concatenate(N_), np.concatenate(Y_)


class _Field(torch.nn.Module):
    """The MLP of a position (scaled to [-1, 1] over lo..hi, ``nfreq`` Fourier octaves) and a unit vector (the
    normal; a reflection map's reflected direction, with ``nfreq_dir`` octaves): lightmap.encode's features."""

    def __init__(self, lo, hi, nfreq: int, hidden: int = HIDDEN, layers: int = LAYERS, nfreq_dir: int = 0):
        super().__init__()
        self.register_buffer("lo", torch.tensor(np.asarray(lo, np.float32)))
        self.register_buffer("hi", torch.tensor(np.asarray(hi, np.float32)))
        self.nfreq, self.nfreq_dir = nfreq, nfreq_dir
        dims = [6 + 6 * nfreq + 6 * nfreq_dir] + [hidden] * layers + [3]
        self.layers = torch.nn.ModuleList(torch.nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:]))

    def forward(self, p, n):
        x = (p - self.lo) / torch.clamp(self.hi - self.lo, min=1e-6) * 2.0 - 1.0
        fs = [x, n]
        for v, octaves in ((x, self.nfreq), (n, self.nfreq_dir)):
            for i in range(octaves):
                fs += [torch.sin(v * (math.pi * 2 ** i)), torch.cos(v * (math.pi * 2 ** i))]
        h = torch.cat(fs, 1)
        for i, layer in enumerate(self.layers):
            h = layer(h)
            if i < len(self.layers) - 1:
                h = torch.relu(h)
        return h


def train_steps(net, loss_of, n: int, seconds: float, steps: int | None, seed: int, log, name: str, lr: float = LR,
                batch: int = BATCH) -> tuple[int, list, float]:
    """Adam on ``loss_of(indices)`` over random batches of ``n`` points, the learning rate on a cosine over
    ``seconds`` (or ``steps`` when that comes first); (steps, losses, seconds). Shared by the shot's lightmap and
    its reflection map (model/learn/reflmap.py)."""
    opt = torch.optim.Adam(net.parameters(), lr)
    g = torch.Generator().manual_seed(seed)
    t0, step, run = time.perf_counter(), 0, []
    while True:
        el = time.perf_counter() - t0
        if el >= seconds or (steps is not None and step >= steps):
            break
        done = max(el / max(seconds, 1e-6), step / steps if steps else 0.0)
        for grp in opt.param_groups:
            grp["lr"] = lr * 0.5 * (1.0 + math.cos(math.pi * min(done, 1.0)))
        loss = loss_of(torch.randint(0, n, (min(batch, n),), generator=g))
        opt.zero_grad()
        loss.backward()
        opt.step()
        step += 1
        run.append(float(loss.detach()))
        if log and step % 1000 == 0:
            log(f"{name}: step {step}, loss {np.mean(run[-200:]):.4f}, {el:.0f} s")
    return step, run, time.perf_counter() - t0


def train_field(pos: np.ndarray, nrm: np.ndarray, y: np.ndarray, seconds: float, seed: int = 0,
                nfreq: int = lm.NFREQ, log=None, steps: int | None = None, known=(),
                signed: bool = False) -> tuple[lm.Lightmap, dict]:
    """Train the MLP on the points for ``seconds`` (module doc, step 2), or ``steps`` steps when that comes first
    (the learning rate's cosine then runs over the steps); returns (Lightmap with lam 0, stats)."""
    if len(pos) < MIN_POINTS:
        raise UserError(f"lightmap: {len(pos)} usable pixels in the training views, at least {MIN_POINTS} needed")
    torch.manual_seed(seed)
    lo, hi = pos.min(0), pos.max(0)
    net = _Field(lo, hi, nfreq)
    P, N, Y = torch.from_numpy(pos), torch.from_numpy(nrm), torch.from_numpy(y)
    step, run, secs = train_steps(net, lambda i: ((net(P[i], N[i]) - Y[i]).abs() / (1.0 + Y[i].abs())).mean(),
                                  len(P), seconds, steps, seed, log, "lightmap")
    weights = [(layer.weight.detach().numpy(), layer.bias.detach().numpy()) for layer in net.layers]
    stats = dict(points=int(len(pos)), steps=step, seconds=secs,
                 loss=float(np.mean(run[-200:])) if run else None, hidden=HIDDEN, layers=LAYERS, nfreq=nfreq,
                 known=list(known))
    return lm.Lightmap(weights, lo, hi, nfreq, 0.0, meta=stats, known=known, signed=signed), stats


def choose_weight(field: lm.Lightmap, data_dir, cameras: dict, keys, predictor, target: str) -> tuple[float, dict]:
    """(lam, {lam: pooled PSNR}) on the validation views ``keys`` (module doc, step 3). ``predictor``: the fitted
    model as the node runs it (``.predict(groups)`` -> diffuse part). Each blend is scored against the fit's target
    over the geometry pixels, as the fit's validation scores the network: the node adds the same EEVEE rest to
    every blend."""
    from ..images import geometry_mask
    want = tuple(dict.fromkeys(tuple(getattr(predictor, "required", ())) + ("albedo", "normal", "depth")))
    pools = {lam: metrics.PooledPSNR() for lam in LAMBDAS}
    for k in keys:
        src = ch.TARGET_SOURCES.get(target, (target,))
        g = exrio.read_sample(folder.sample_path(data_dir, str(k)), tuple(dict.fromkeys(want + src + field.known)))  # UserError names a missing group
        c = cameras[str(k)]
        part = predictor.predict({w: g[w] for w in want})
        light = field.light(g, c["M"], c["P"])
        mask = geometry_mask(g["depth"], g["normal"])
        y = view_target(g, target)[mask]
        for lam in LAMBDAS:
            w = lm.blend_weight(g, lam)[..., None]
            p = w * g["albedo"][..., :3] * light + (1.0 - w) * part
            pools[lam].add(p[mask], y)
    scores = {lam: pools[lam].value for lam in LAMBDAS}
    top = max(scores.values())
    best = max(lam for lam in LAMBDAS if scores[lam] >= top - TIE_DB)
    return best, scores


def fit_lightmap(data_dir, cameras: dict, train, val, predictor, target: str, seconds: float, seed: int = 0,
                 log=None, steps: int | None = None) -> tuple[lm.Lightmap, dict]:
    """Points, training, blend weight (module doc). Two fields when the model's inputs include direct light
    (``lightmap.known_for``): one of the whole diffuse light and one of the light minus that direct light, half the
    time each; the one (and the weight) with the best validation PSNR is kept. Returns (Lightmap with its lam,
    report dict). ``steps``: bound each field's training by steps too (tests)."""
    t0 = time.perf_counter()
    known = lm.known_for(getattr(predictor, "required", ()))
    ways = [()] + ([known] if known else [])
    tried, best = {}, None
    for n, kn in enumerate(ways):
        left = max(seconds - (time.perf_counter() - t0), 1.0) / (len(ways) - n)
        t1 = time.perf_counter()
        pos, nrm, y = points(data_dir, cameras, train, target, kn)
        field, stats = train_field(pos, nrm, y, max(left - (time.perf_counter() - t1), 1.0), seed=seed, log=log,
                                   steps=steps, known=kn, signed=ch.signed_part(target))
        lam, scores = choose_weight(field, data_dir, cameras, val, predictor, target)
        name = "+".join(kn) or "none"
        tried[name] = dict(stats, lam=lam, val_psnr={str(k): round(v, 3) for k, v in scores.items()})
        if log:
            log(f"lightmap (known light: {name}): {stats['points']} points, {stats['steps']} steps; val PSNR by "
                "weight " + ", ".join(f"{k:g}: {v:.2f}" for k, v in scores.items()) + f"; weight {lam:g}")
        if best is None or max(scores.values()) > max(best[2].values()):
            best = (field, lam, scores, stats, kn)
    field, lam, scores, stats, kn = best
    field.lam = lam
    rep = dict(stats, lam=lam, val_psnr={str(k): round(v, 3) for k, v in scores.items()},
               seconds_total=time.perf_counter() - t0, target=target, known=list(kn), tried=tried)
    field.meta = rep
    if log:
        log(f"lightmap: kept known light {'+'.join(kn) or 'none'}, weight {lam:g}")
    return field, rep
