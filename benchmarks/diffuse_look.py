"""Benchmark: the diffuse part each model predicts on a dataset folder, beside Cycles' own.

For each sample of --data (e.g. a report's 1-sample bake of the artist test set, REPORT/data) and each --models
checkpoint: the network's prediction of the diffuse part (Predictor.predict, as the node runs it, from the sample's
stored groups) against the sample's ``ref_diffuse``: PSNR over the geometry pixels, and the mean prediction /
reference (brightness). With --out, a PNG sheet: one row a sample, Cycles' diffuse part then each model's
(images.srgb8).

    .venv/bin/python benchmarks/diffuse_look.py --data out/reports/artist/data --models OLD.pt NEW.pt --out sheet.png
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package ssgi)
import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="a dataset folder whose samples hold ref_diffuse")
    ap.add_argument("--models", nargs="+", required=True)
    ap.add_argument("--out", default=None, help="PNG sheet")
    a = ap.parse_args(argv)

    from ssgi.model import images, metrics
    from ssgi.model.errors import UserError
    from ssgi.model.learn import data
    from ssgi.model.infer.predictor import load_predictor

    try:
        stored = data.StoredSamples(a.data)
        preds = [load_predictor(Path(m), num_threads=2) for m in a.models]
    except UserError as e:
        print(f"diffuse_look: {e}", file=sys.stderr)
        return 2
    rows = []
    for key in sorted(stored.raw):
        g = stored.raw[key]
        if "ref_diffuse" not in g:
            print(f"diffuse_look: {a.data}: sample {key} holds no ref_diffuse", file=sys.stderr)
            return 2
        ref = g["ref_diffuse"][..., :3]
        mask = images.geometry_mask(g["depth"], g["normal"])
        row = [ref]
        cells = []
        for m, p in zip(a.models, preds):
            out = p.predict({k: v for k, v in g.items() if k in set(p.required) | {"normal", "depth", "albedo"}})
            s = metrics.score(out, ref, mask, with_ssim=False, with_flip=False)
            ratio = float(out[mask].mean() / max(1e-8, ref[mask].mean()))
            cells.append(f"{Path(m).name} {s['psnr']:.2f} dB {ratio:.2f}x")
            row.append(out)
        print(f"{stored.scene[key]}: " + "; ".join(cells))
        rows.append(np.concatenate([np.pad(x, ((0, 2), (0, 2), (0, 0))) for x in row], axis=1))
    if a.out:
        images.write_png(Path(a.out), images.srgb8(np.concatenate(rows, axis=0)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
