"""Validation metrics of a network on whole images (bpy-free): what training's validation, the linear
baseline and the fit score a network by (``evaluate``), over the geometry pixels (``geometry``)."""
from __future__ import annotations

import math

import numpy as np
import torch

from .. import metrics, normalize
from . import data, network


def geometry(s: data.Sample) -> torch.Tensor:
    """H x W bool mask of the pixels a model is scored on (all when the sample has no mask)."""
    return s.mask if s.mask is not None else torch.ones(s.y.shape[1:], dtype=torch.bool)


def evaluate(net, samples, with_ssim: bool = True) -> dict:
    """Validation metrics over the geometry pixels of whole images (data.Sample.mask): PSNR by the seed's
    convention and after the tonemap, pooled over all those pixels of all images; log-space MSE (the loss);
    mean SSIM of the image with the reference composited where nothing was hit (as the node shows it).
    Samples of several dataset folders (keys ``<tag>/<key>``, data.FolderSet) are also scored per folder
    (``val_folders``: tag -> pooled PSNR), and ``val_score``, what training keeps its best checkpoint by, is the
    mean of those: a folder of 40 rooms counts as much as one of 500 (pooled, the big folder decides alone).
    With one folder ``val_score`` is ``val_psnr``."""
    p, tp = metrics.PooledPSNR(), metrics.PooledPSNR(tonemapped=True)
    per: dict[str, metrics.PooledPSNR] = {}
    ss, sq, n = [], 0.0, 0
    net.eval()
    dev = next(net.parameters(), torch.empty(0)).device  # a network on a GPU is scored there, the metrics on the CPU
    with torch.inference_mode():
        for s in samples:
            out = net(s.x[None].to(dev).contiguous(memory_format=torch.channels_last)).float().cpu()
            m = geometry(s)
            sq += float((((out - normalize.light_forward(s.y[None])) ** 2) * m).sum())
            n += 3 * int(m.sum())
            pred = network.to_linear(out)[0].permute(1, 2, 0).numpy()
            r = metrics.score(pred, s.y.permute(1, 2, 0).numpy(), m.numpy(), with_ssim=with_ssim, with_flip=False)
            p.add_score(r)
            tp.add_score(r)
            per.setdefault(s.key.split("/", 1)[0] if "/" in s.key else "", metrics.PooledPSNR()).add_score(r)
            if with_ssim:
                ss.append(r["ssim"])
    net.train()
    out = dict(val_psnr=p.value, val_tm_psnr=tp.value, val_ssim=float(np.mean(ss)) if ss else math.nan,
               val_loss=sq / max(n, 1), val_score=p.value)
    if len(per) > 1:
        out["val_folders"] = {t: v.value for t, v in sorted(per.items())}
        out["val_score"] = float(np.mean(list(out["val_folders"].values())))
    return out
