"""Numbers behind docs/hard_cases.md (not a test): trains the suite's two tiny models and measures the
output bound, precision agreement, tiling differences, and the lr-10 run.

    .venv/bin/python tests/hard_cases/measure.py
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
import cli  # noqa: E402

cli.load_package()

import numpy as np  # noqa: E402
import torch  # noqa: E402

from ssgi.model.infer import predictor
from ssgi.model.dataset import exrio, synthetic
from ssgi.model import metrics  # noqa: E402
from ssgi.model.infer.bench import synthetic_groups  # noqa: E402
from ssgi.model.learn.train import Trainer  # noqa: E402

sys.path.insert(0, str(ROOT / "tests" / "hard_cases"))
from conftest import MODELS, train_cfg  # noqa: E402


def main() -> None:
    torch.set_num_threads(1)
    d = Path(tempfile.mkdtemp(prefix="hard-measure-"))
    data = synthetic.make_dataset(d / "data", scenes=4, per_scene=2, w=48, h=32, seed=5)
    models = {}
    for v in MODELS:
        models[v] = d / f"{v}.pt"
        t = time.perf_counter()
        res = Trainer(train_cfg(data, models[v], v), log=lambda m: None).run()
        print(f"train {v}: {time.perf_counter() - t:.1f} s, val PSNR {res['best']['val_psnr']:.2f} dB")

    print("\n# case 2: output / max(1, peak input light), lights scaled")
    for v, path in models.items():
        for prec in predictor.PRECISIONS:
            pred = predictor.load_predictor(path, precision=prec)
            row = []
            for light in (1.0, 1e2, 1e4, 1e5 / 3, 3e38):
                g = synthetic_groups(40, 24, 3)
                g["direct"] = np.minimum(g["direct"].astype(np.float64) * light, 3.4e38).astype(np.float32)
                out = pred.predict(g)
                peak = float(np.minimum(g["direct"], 65504).max())
                row.append(f"x{light:.0e}: {out.max() / max(1.0, peak):.3g}")
            print(f"{v:7s} {prec:8s} " + "  ".join(row))

    print("\n# case 6: tonemapped PSNR / seed's PSNR vs fp32, direct log-uniform 1e-3..1e3")
    for v, path in models.items():
        g = synthetic_groups(64, 40, 9)
        g["direct"] = (10.0 ** np.random.default_rng(9).uniform(-3, 3, g["direct"].shape)).astype(np.float32)
        ref = predictor.load_predictor(path, precision="fp32").predict(g)
        for prec in ("fp32-cl", "bf16-cl"):
            out = predictor.load_predictor(path, precision=prec).predict(g)
            print(f"{v:7s} {prec:8s} tm {metrics.tm_psnr(out, ref):7.2f} dB  seed {metrics.psnr(out, ref):7.2f} dB  "
                  f"max rel diff {np.max(np.abs(out - ref) / (ref + 1e-3)):.2g}")
    g = synthetic_groups(48, 32, 11)
    g["direct"] *= np.float32(50)
    g.update(eevee=np.zeros((32, 48, 4), np.float32), ref=np.zeros((32, 48, 3), np.float32))
    outs = []
    for half in (True, False):
        exrio.write_sample(d / "s.exr", g, half=half)
        outs.append(predictor.load_predictor(models["unet_s"]).predict(exrio.read_sample(d / "s.exr")))
    print(f"half vs float EXR inputs (unet_s, direct x50): tm {metrics.tm_psnr(outs[0], outs[1]):.2f} dB")

    print("\n# case 5: tiled vs untiled, max |difference|")
    for v, path in models.items():
        pred = predictor.load_predictor(path)
        for h, w, tile in ((1081, 1921, predictor.DEFAULT_TILE), (301, 9, 4), (3, 2500, 4), (29, 53, 8)):
            if v == "fssgi" and h * w > 1e6:
                continue
            g = synthetic_groups(w, h, h + w)
            t = time.perf_counter()
            full = pred.predict(g, tile=None)
            t1 = time.perf_counter() - t
            t = time.perf_counter()
            tiled = pred.predict(g, tile=tile)
            t2 = time.perf_counter() - t
            print(f"{v:7s} {w}x{h} tile {tile}: max |diff| {np.abs(full - tiled).max():.3g}  "
                  f"untiled {t1:.2f} s, tiled {t2:.2f} s")

    print("\n# case 7: lr 10 from scratch (unet_s, 4 epochs)")
    msgs = []
    res = Trainer(train_cfg(data, d / "lr10.pt", epochs=4, lr=10.0), log=msgs.append).run()
    print(f"status {res['status']}, skipped steps {res['skipped_steps']}, lr halvings {res['lr_drops']}, "
          f"best val PSNR {res['best']['val_psnr']:.2f} dB at epoch {res['best']['epoch']}")
    res = Trainer(train_cfg(data, d / "lr3e-3.pt", epochs=4), log=lambda m: None).run()
    print(f"same at lr 3e-3: best val PSNR {res['best']['val_psnr']:.2f} dB")


if __name__ == "__main__":
    main()
