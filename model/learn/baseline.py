"""The per-pixel linear-regression baseline, fitted in closed form (bpy-free).

For every training pixel with geometry (data.Sample.mask) the features are the network's normalised inputs (normalize.to_inputs, the same
input spec) plus a constant 1; the target is the Cycles reference. Least squares over all training pixels:
w = (X^T X + lambda I)^-1 X^T y, accumulated in float64, with a tiny ridge lambda = 1e-6 * trace(X^T X) / n
only to keep a rank-deficient X^T X solvable (e.g. a constant input channel).

Space: ``linear`` (default) regresses linear RGB, as the seed did, which minimises the squared error the
seed's PSNR measures (before its clamp); ``log`` regresses log1p(RGB), the network's loss space. The
prediction is clamped at 0 (linear) and the result stored as a ``PixelLinear`` module in the ordinary
checkpoint format (kind "linear"), so predict/report treat it like any model. The split into train and
validation scenes is the trainer's (same seed and fraction), so their validation numbers compare.
"""
from __future__ import annotations

import sys
import time

import numpy as np
import torch

from .. import channels as ch
from . import checkpoint, data, network
from .. import normalize
from .validation import evaluate, geometry


def fit(samples, space: str = "linear") -> tuple[np.ndarray, np.ndarray]:
    """(weight C x 3, bias 3) of the least-squares fit over all pixels of ``samples``."""
    c = samples[0].x.shape[0]
    xtx = np.zeros((c + 1, c + 1))
    xty = np.zeros((c + 1, 3))
    for s in samples:
        keep = geometry(s).reshape(-1)
        x = s.x.reshape(c, -1).T[keep].double().numpy()
        x = np.concatenate([x, np.ones((x.shape[0], 1))], axis=1)
        y = s.y.reshape(3, -1).T[keep].double()
        y = (normalize.light_forward(y) if space == "log" else y).numpy()
        xtx += x.T @ x
        xty += x.T @ y
    lam = 1e-6 * np.trace(xtx) / (c + 1)
    w = np.linalg.solve(xtx + lam * np.eye(c + 1), xty)
    return w[:c], w[c]


def run_baseline(data_dir, out, inputs=ch.DEFAULT_INPUTS, space="linear", seed=0, val_fraction=0.2,
                 dataset=None, command=None, log=None) -> dict:
    log = log or (lambda m: print(m, file=sys.stderr, flush=True))
    spec = ch.parse_spec(inputs)
    t0 = time.perf_counter()
    ds = dataset or data.DatasetFolder.load(data_dir, spec)
    train_sc, val_sc = data.split_scenes(ds.scenes, val_fraction, seed)
    tr, va = ds.subset(train_sc), ds.subset(val_sc)
    w, b = fit(tr, space)
    net = network.build(network.arch_for("linear", spec, target=ds.target, space=space))
    with torch.no_grad():
        net.conv.weight.copy_(torch.from_numpy(w.T.astype(np.float32))[:, :, None, None])
        net.conv.bias.copy_(torch.from_numpy(b.astype(np.float32)))
    ev = evaluate(net, va)
    tr_ev = evaluate(net, tr, with_ssim=False)
    minutes = (time.perf_counter() - t0) / 60
    entry = dict(epoch=1, step=0, minutes=minutes, loss=tr_ev["val_loss"], train_psnr=tr_ev["val_psnr"], **ev)
    ident = dict(ds.identity(), split=dict(train=train_sc, val=val_sc, val_fraction=val_fraction, seed=seed))
    checkpoint.save(out, checkpoint.make(net, "linear", history=[entry], best=entry, dataset=ident, command=command))
    log(f"linear baseline ({space} space, {len(tr)} train / {len(va)} val samples): val PSNR {ev['val_psnr']:.2f} dB "
        f"(tm {ev['val_tm_psnr']:.2f}, SSIM {ev['val_ssim']:.3f}); train PSNR {tr_ev['val_psnr']:.2f} dB")
    return dict(model=str(out), space=space, best=entry, train_scenes=len(train_sc), val_scenes=len(val_sc))
