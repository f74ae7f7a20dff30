"""Contact sheet of a fitted model on its held-out test views: EEVEE direct | fitted prediction | Cycles.

    .venv/bin/python docs/fit_look.py MODEL.pt OUT.png

Reads the views folder and the test keys from the checkpoint's fit report (bpy-free).
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import cli  # noqa: E402

cli.load_package()
from ssgi.model import checkpoint, exrio, metrics  # noqa: E402
from ssgi.model.predict import srgb8, write_png  # noqa: E402


def main(model, out):
    ck = checkpoint.load(model)
    rep = ck["fit"]
    pred = checkpoint.load_predictor(model)
    rows = []
    for key in rep["views"]["test"] or rep["views"]["val"]:
        g = exrio.read_sample(Path(rep["data"]) / f"{key}.exr")
        p = pred.predict(g)
        print(f"{key}: PSNR {metrics.psnr(p, g['ref']):.2f} dB (EEVEE direct {metrics.psnr(g['eevee'][..., :3], g['ref']):.2f})")
        rows.append(np.concatenate([srgb8(g["eevee"][..., :3]), srgb8(p), srgb8(g["ref"])], axis=1))
    write_png(out, np.concatenate(rows, axis=0))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
