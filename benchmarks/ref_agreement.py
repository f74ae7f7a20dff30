"""Benchmark: self-agreement of the Cycles reference, by samples and denoising.

Two references of the same room with different Cycles seeds; PSNR between them by the seed's convention
(linear RGB clamped to [0,1], MSE pooled over the image), and seconds per reference.

    .venv/bin/python benchmarks/ref_agreement.py --rooms 0 1 2 --spp 8 16 32 --size 240x135
    .venv/bin/python benchmarks/ref_agreement.py --rooms 1 --spp 1024 --raw-only   # no OIDN (the default)
"""
import argparse
import json
import sys
import time

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402

from ssgi.model import metrics  # noqa: E402
from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import passes  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--rooms", type=int, nargs="+", default=[0, 1, 2])
ap.add_argument("--spp", type=int, nargs="+", default=[8, 16, 32])
ap.add_argument("--size", type=parse_size, default=(240, 135))
ap.add_argument("--raw", action="store_true", help="also without OIDN")
ap.add_argument("--raw-only", action="store_true", help="only without OIDN")
a = ap.parse_args()
MODES = [False] if a.raw_only else ([True, False] if a.raw else [True])
rows = []
for r, scene in _bootstrap.rooms(a.rooms, a.size):
    for spp in a.spp:
        for dn in MODES:
            imgs, ts = [], []
            for seed in (1, 2):
                t = time.perf_counter()
                imgs.append(passes.render_cycles(scene, spp, seed=seed, denoise=dn)["ref"])
                ts.append(time.perf_counter() - t)
            p = metrics.psnr(imgs[0], imgs[1])
            row = dict(room=r, spp=spp, denoise=dn, psnr=round(p, 2), seconds=round(min(ts), 3),
                       mean=round(float(np.mean(imgs[0])), 4))
            rows.append(row)
            print(json.dumps(row), flush=True)
print("summary (min PSNR over rooms, mean seconds):", file=sys.stderr)
for spp in a.spp:
    for dn in MODES:
        sel = [x for x in rows if x["spp"] == spp and x["denoise"] == dn]
        print(f"  spp={spp:4d} denoise={dn}: min {min(x['psnr'] for x in sel):.2f} dB, "
              f"mean {np.mean([x['psnr'] for x in sel]):.2f} dB, {np.mean([x['seconds'] for x in sel]):.2f} s",
              file=sys.stderr)
