"""The Cycles reference of a dataset sample: a fixed sample count, or two halves of different seeds doubled until
two such references would agree to a target PSNR (``render_reference``). The constants are the baker's
measured defaults (docs/bake.md)."""
from __future__ import annotations

import math

import numpy as np

from ...model import metrics
from ...model.errors import UserError
from . import passes

# Cycles reference, measured in docs/bake.md (benchmarks/ref_agreement.py, the seed's convention). The default
# is the raw path-traced reference; OIDN is an option, off by default (a denoiser can bias the target). Raw
# agreement grows 3.0 dB per doubling of samples; at 256 spp 20 rooms gave 29.9-55.0 dB, the worst (room 4)
# 32.9 dB at 512, 36.0 dB at 1024 and 41.97 dB at 4096: so no room needs more than 4096, the most a reference
# takes, and most need far fewer (the target below). The fast alternative, recorded in the manifest when
# chosen: --denoise at 64 spp agrees to >= 40.5 dB in the 7 rooms measured, ~90x faster than 4096 raw; the
# shipped model's training bake used --denoise --ref-samples 16 (36.8-48.9 dB).
DEFAULT_REF_SAMPLES = 4096
# Per sample, the raw reference is rendered as two halves with different seeds until the halves agree well
# enough: two whole references (each the mean of two halves) agree about 3.01 dB better than two halves (half the
# variance), so the bake stops at the first doubling where psnr(half A, half B) + 3.01 >= the target, or at
# DEFAULT_REF_SAMPLES. Each sample's samples and estimated agreement go into the manifest; the estimate is checked
# against two independent references in benchmarks/ref_target.py (docs/bake.md). 0 = a fixed sample count.
# The bar is 40 dB; the default aims 1 dB higher because the estimate is itself measured: at 240x135 it
# came within 0.1 dB of the truth, and one room estimated at 40.01 measured 39.99.
DEFAULT_REF_TARGET_DB = 41.0
REF_START_SAMPLES = 256  # the first two halves: 128 spp each
HALVES_GAIN_DB = 10.0 * math.log10(2.0)  # 3.01 dB: a reference of both halves against another such reference
# Render i of a reference of seed s uses Cycles seed s * REF_SEED_STRIDE + i, so that references of different
# seeds never share a render's seed; a reference therefore makes fewer than REF_SEED_STRIDE renders.
REF_SEED_STRIDE = 64
DENOISED_REF_SAMPLES = 64


def resolve_ref_target(ref_target_db, denoise: bool) -> float | None:
    """The reference's agreement target in dB, or None for a fixed sample count. The default (None) is
    DEFAULT_REF_TARGET_DB for a raw reference and a fixed count with --denoise (the mean of two denoised halves
    is not a denoised reference, and OIDN's agreement does not grow by 3 dB per doubling)."""
    if ref_target_db is None:
        return None if denoise else DEFAULT_REF_TARGET_DB
    if ref_target_db < 0 or not math.isfinite(ref_target_db):
        raise UserError(f"--ref-target-db {ref_target_db}: must be a finite number >= 0 (0: a fixed sample count)")
    if ref_target_db == 0:
        return None
    if denoise:
        raise UserError(f"--ref-target-db {ref_target_db:g} with --denoise: a target needs raw halves; with "
                        "--denoise the reference takes exactly --ref-samples (give --ref-target-db 0 or leave it out)")
    return float(ref_target_db)


def render_reference(scene, max_samples: int, target_db: float | None, seed: int = 0, denoise: bool = False):
    """The Cycles reference image of ``scene``: (HxWx3, info); ``render_references`` with the group "ref"."""
    imgs, info = render_references(scene, max_samples, target_db, seed=seed, denoise=denoise)
    return imgs["ref"], info


def render_references(scene, max_samples: int, target_db: float | None, seed: int = 0, denoise: bool = False,
                      groups=("ref",)):
    """The Cycles reference groups of ``scene`` ("ref", and "ref_diffuse", the diffuse part, from the same
    renders): ({group: HxWx3}, info). With a target, two halves of different seeds are rendered and doubled
    (128+128 spp, then 256+256, ...) until psnr(half A, half B) + 3.01 dB of the "ref" image >= ``target_db``
    or ``max_samples`` is spent; each group is the mean of both halves (each half the spp-weighted mean of its
    renders: unbiased, as one render of as many samples). ``info``: samples, estimated agreement in dB (None
    for a fixed count) and the number of Cycles renders."""
    groups = tuple(dict.fromkeys(("ref",) + tuple(groups)))
    if target_db is None or max_samples < 2:
        imgs = passes.render_cycles(scene, max_samples, seed=seed, denoise=denoise, groups=groups)
        return imgs, {"samples": int(max_samples), "agreement_db": None, "renders": 1}
    sums, n, renders = [None, None], 0, 0  # per half: {group: sum of spp * image}; spp per half so far
    add = max(1, min(REF_START_SAMPLES, max_samples) // 2)
    while True:
        for h in (0, 1):
            cycles_seed = (int(seed) * REF_SEED_STRIDE + renders) % 2 ** 31
            imgs = passes.render_cycles(scene, add, seed=cycles_seed, groups=groups)
            imgs = {g: v.astype(np.float64) * add for g, v in imgs.items()}
            sums[h] = imgs if sums[h] is None else {g: sums[h][g] + imgs[g] for g in groups}
            renders += 1
        n += add
        est = metrics.psnr(sums[0]["ref"] / n, sums[1]["ref"] / n) + HALVES_GAIN_DB
        add = min(n, max_samples // 2 - n)  # double each half, never past max_samples
        if est >= target_db or add <= 0 or renders + 2 >= REF_SEED_STRIDE:
            break
    out = {g: ((sums[0][g] + sums[1][g]) / (2 * n)).astype(np.float32) for g in groups}
    return out, {"samples": 2 * n, "agreement_db": round(float(min(est, 999.0)), 2), "renders": renders}
