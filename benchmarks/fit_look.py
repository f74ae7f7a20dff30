"""Contact sheet of a fitted model on its held-out test views: EEVEE direct | generic | fitted | Cycles.

    .venv/bin/python benchmarks/fit_look.py MODEL.pt OUT.png [--scale 2]

Reads the views folder, the test keys and the generic model's path from the checkpoint's fit report
(bpy-free); the generic column is left out when the fit had no generic model. Prints each view's PSNR.
"""
import argparse
from pathlib import Path

import numpy as np

import _bootstrap  # noqa: E402, F401  (the checkout as package ssgi)
from ssgi.model.infer import predictor  # noqa: E402
from ssgi.model.learn import checkpoint
from ssgi.model.dataset import exrio
from ssgi.model import metrics  # noqa: E402
from ssgi.model.images import srgb8, write_png  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("model")
    ap.add_argument("out")
    ap.add_argument("--scale", type=int, default=1, help="repeat each pixel N times (nearest) for viewing")
    a = ap.parse_args(argv)
    rep = checkpoint.load(a.model)["fit"]
    pred = predictor.load_predictor(a.model)
    gpath = (rep.get("generic") or {}).get("path")
    gen = predictor.load_predictor(gpath) if gpath and Path(gpath).is_file() else None
    rows = []
    for key in rep["views"]["test"] or rep["views"]["val"]:
        g = exrio.read_sample(Path(rep["data"]) / f"{key}.exr")
        p = pred.predict(g)
        cols = [srgb8(g["eevee"][..., :3])]
        msg = f"{key}: EEVEE direct {metrics.psnr(g['eevee'][..., :3], g['ref']):.2f} dB"
        if gen is not None:
            q = gen.predict(g)
            cols.append(srgb8(q))
            msg += f", generic {metrics.psnr(q, g['ref']):.2f} dB"
        cols += [srgb8(p), srgb8(g["ref"])]
        print(msg + f", fitted {metrics.psnr(p, g['ref']):.2f} dB")
        rows.append(np.concatenate(cols, axis=1))
    img = np.concatenate(rows, axis=0)
    if a.scale > 1:
        img = img.repeat(a.scale, axis=0).repeat(a.scale, axis=1)
    write_png(a.out, img)


if __name__ == "__main__":
    main()
