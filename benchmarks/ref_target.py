"""Benchmark: the per-sample reference target (reference.render_reference), checked against the truth.

For each room, two references made the way the baker makes them (halves of different seeds, doubled until the
halves' PSNR + 3.01 dB reaches the target, or --ref-samples is spent), from two disjoint sets of seeds. Prints
each one's samples, estimated agreement and seconds, and the PSNR measured between the two (the seed's
convention: linear RGB clamped to [0,1], MSE pooled), which the estimate claims to predict.

    .venv/bin/python benchmarks/ref_target.py --rooms 0 1 2 3 13 --target 40
"""
import argparse
import json
import sys
import time

import _bootstrap  # noqa: E402  (the checkout as package ssgi)

from ssgi.model import metrics  # noqa: E402
from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import reference  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--rooms", type=int, nargs="+", default=[0, 1, 2])
ap.add_argument("--target", type=float, default=reference.DEFAULT_REF_TARGET_DB)
ap.add_argument("--ref-samples", type=int, default=reference.DEFAULT_REF_SAMPLES, help="most samples")
ap.add_argument("--size", type=parse_size, default=(240, 135))
a = ap.parse_args()
rows = []
for r, scene in _bootstrap.rooms(a.rooms, a.size):
    refs, infos, secs = [], [], []
    for s in (r * 2 + 1000, r * 2 + 1001):  # disjoint seed sets (reference.REF_SEED_STRIDE)
        t = time.perf_counter()
        img, info = reference.render_reference(scene, a.ref_samples, a.target, seed=s)
        secs.append(round(time.perf_counter() - t, 1))
        refs.append(img)
        infos.append(info)
    row = dict(room=r, spp=[i["samples"] for i in infos], estimated_db=[i["agreement_db"] for i in infos],
               measured_db=round(metrics.psnr(refs[0], refs[1]), 2), seconds=secs)
    rows.append(row)
    print(json.dumps(row), flush=True)
print(f"target {a.target:g} dB: measured {min(x['measured_db'] for x in rows):.2f}-"
      f"{max(x['measured_db'] for x in rows):.2f} dB; estimate - measured "
      f"{min(min(x['estimated_db']) - x['measured_db'] for x in rows):+.2f} to "
      f"{max(max(x['estimated_db']) - x['measured_db'] for x in rows):+.2f} dB", file=sys.stderr)
