"""Benchmark: the shipped model at full resolution against prediction at working resolutions
(1/2, 1/4, 1/8 linear), upsampled bilinearly or guided, with and without the full-resolution direct light,
on baked dataset folders at any size. Scores (PSNR, SSIM, FLIP over the geometry pixels, at the output size,
against the folder's Cycles reference ``ref``) the SSGI image as the node composes it (prediction + ``rest``
when the sample holds ``rest``), and the time and peak memory of the prediction (reduce + network + upsample +
composition), each in this process with VmHWM reset before it.

    .venv/bin/python benchmarks/working_res.py --data data/wr/rooms960 [data/diffuse_val ...] \\
        [--model models/ssgi_default.pt] [--factors 2,4,8] [--threads 2] [--limit 6] [--crops DIR] [--json OUT]
    .venv/bin/python benchmarks/working_res.py --time-at 1920x1080 [--factors 4]     # time and memory only
                                        # (no emitter, and one emitter panel: model/infer/fine.py's cost)

Prints one table row per (folder, configuration): mean PSNR / SSIM / FLIP over the folder's samples, the median
prediction time (wall and CPU of all threads: on a loaded machine the CPU time is the steadier number)
and the largest peak-memory growth. ``--crops DIR`` writes, for the first sample of each folder,
side-by-side crops (full resolution | 1/4 bilinear | 1/4 guided | 1/4 guided+direct | reference) of the
region where the bilinear and the guided upsample differ most as shown, magnified 3x (images.srgb8).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package "ssgi")
import numpy as np

from ssgi.model import images, metrics
from ssgi.model.dataset import exrio, folder
from ssgi.model.infer import bench, compose, workres
from ssgi.model.infer.predictor import load_predictor

METHODS = (("bilinear", False), ("guided", False), ("bilinear", True), ("guided", True))


def label(f: int, method: str, residual: bool) -> str:
    return "full" if f == 1 else f"1/{f} {method}{'+direct' if residual else ''}"


def predict_timed(pred, groups, target) -> tuple[np.ndarray, float, float, float]:
    """(image, wall seconds, CPU seconds of all threads, peak memory growth MB) of prediction + composition."""
    before = bench._vm("VmRSS")
    bench._reset_peak()
    t, c = time.perf_counter(), time.process_time()
    img = compose.compose(pred.predict(groups), groups, target) if "rest" in groups else pred.predict(groups)
    dt, dc = time.perf_counter() - t, time.process_time() - c
    return img, dt, dc, max(0, bench._vm("VmHWM") - before) / 2 ** 20


def crop_sheet(path, imgs: dict, ref: np.ndarray, a: np.ndarray, b: np.ndarray, size=(160, 90), zoom=3) -> tuple:
    """Side-by-side crops of the region where a and b differ most as shown (box-filtered |sRGB(a) - sRGB(b)|)."""
    from scipy.ndimage import uniform_filter
    d = uniform_filter(np.abs(images.srgb(a) - images.srgb(b)).sum(-1), size=(size[1], size[0]), mode="constant")
    H, W = d.shape
    cy, cx = np.unravel_index(np.argmax(d), d.shape)
    y0, x0 = int(np.clip(cy - size[1] // 2, 0, H - size[1])), int(np.clip(cx - size[0] // 2, 0, W - size[0]))
    tiles = [images.srgb8(im[y0:y0 + size[1], x0:x0 + size[0]]) for im in list(imgs.values()) + [ref]]
    sep = np.full((size[1], 4, 3), 255, np.uint8)
    row = np.concatenate(sum(([t, sep] for t in tiles), [])[:-1], axis=1)
    images.write_png(path, row.repeat(zoom, 0).repeat(zoom, 1))
    return x0, y0


def time_at(pred, w: int, h: int, configs, threads: int, repeats: int = 5, model=None) -> list[dict]:
    """Time and peak memory of each configuration at w x h on the benchmark's synthetic inputs (the work does
    not depend on the content but for emitters: none here, ``emission`` is black): the median of ``repeats`` after
    a warm-up, per stage. ``cold_mb``: the peak growth of one cold prediction in a fresh process
    (bench.peak_memory; the default guided upsample). The default upsample at a working resolution runs again
    "+ emitter panel": with one emissive rectangle of the Cornell panel's share of the frame at 960x540 (126 x 33
    px: 13 % of the width, 6 % of the height), where the network also runs at full resolution (model/infer/fine.py)."""
    g = bench.synthetic_groups(w, h)
    g["rest"] = np.zeros((h, w, 3), np.float32)
    g["emission"] = np.zeros((h, w, 3), np.float32)
    panel = dict(g, emission=g["emission"].copy())
    pw, ph = round(0.13 * w), round(0.06 * h)
    panel["emission"][h // 20:h // 20 + ph, (w - pw) // 2:(w + pw) // 2] = 20.0
    todo = [(c, g, "") for c in configs]
    todo += [((f, m, r), panel, " + emitter panel") for f, m, r in configs if f > 1 and (m, r) == ("guided", False)]
    rows = []
    for (f, m, r), g, extra in todo:
        wpred = workres.WorkingResolution(pred, f if f > 1 else "full", method=m, residual=r, threads=threads)
        predict_timed(wpred, g, pred.target)
        runs = [predict_timed(wpred, g, pred.target)[1:] + (dict(wpred.last_seconds),) for _ in range(repeats)]
        row = dict(size=f"{w}x{h}", config=label(f, m, r) + extra, seconds=float(np.median([x[0] for x in runs])),
                   fine_pixels=int(getattr(wpred, "last_fine_pixels", 0)),
                   cpu_seconds=float(np.median([x[1] for x in runs])), peak_mb=max(x[2] for x in runs),
                   **{f"t_{k}": float(np.median([x[3][k] for x in runs])) for k in runs[0][3]})
        if model is not None and not extra and (f == 1 or (m, r) == ("guided", False)):
            row["cold_mb"] = bench.peak_memory(model, w, h, threads, working_res=f"{f}x").get("peak_mb")
        rows.append(row)
        print(f"{row.get('cold_mb') or 0:5.0f} MB cold  {row['size']:>9} {row['config']:<22} {row['seconds']:7.3f} s wall {row['cpu_seconds']:7.3f} s CPU "
              f"+{row['peak_mb']:4.0f} MB  fine px {row['fine_pixels']:6d}  " + " ".join(f"{k[2:]} {v:.3f}" for k, v in row.items() if k.startswith("t_")),
              flush=True)
    return rows


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", nargs="*", default=[], help="dataset folders (each holds ref)")
    ap.add_argument("--time-at", nargs="*", default=[], metavar="WxH",
                    help="also time every configuration at these sizes on synthetic inputs (5 runs each)")
    ap.add_argument("--model", default=str(_bootstrap.ROOT / "models" / "ssgi_default.pt"))
    ap.add_argument("--factors", default="2,4,8")
    ap.add_argument("--threads", type=int, default=2, help="torch and upsample threads (2)")
    ap.add_argument("--limit", type=int, default=0, help="at most this many samples a folder (0: all)")
    ap.add_argument("--keys", nargs="*", default=None, help="only these sample keys (e.g. 000002)")
    ap.add_argument("--no-flip", action="store_true", help="skip FLIP (slow at 1080p)")
    ap.add_argument("--crops", help="folder for the side-by-side crop PNGs")
    ap.add_argument("--json", help="write every per-sample row here")
    a = ap.parse_args(argv)
    factors = [int(x) for x in a.factors.split(",") if x]
    pred = load_predictor(a.model, num_threads=a.threads)
    configs = [(1, "guided", True)] + [(f, m, r) for f in factors for m, r in METHODS]
    rows = []
    for z in a.time_at:
        w, h = (int(v) for v in z.lower().split("x"))
        rows += time_at(pred, w, h, configs, a.threads, model=a.model)
    for d in a.data:
        man = folder.open_folder(d)
        keys = [k for k in sorted(man["samples"]) if a.keys is None or k in a.keys][: a.limit or None]
        for i, key in enumerate(keys):
            path = folder.sample_path(d, key)
            planes, _ = exrio.read_exr(path)
            have = tuple(g for g in set(pred.required) | {"depth", "normal", "albedo", "rest", "ref"}
                         if any(c.startswith(g + ".") for c in planes))
            g = exrio.read_sample(path, have, strict=False)
            for name in pred.required:  # older bakes lack some optional inputs: zeros, as the loader does
                g.setdefault(name, np.zeros(g["albedo"].shape[:2] + (3,), np.float32))
            inp = {k: v for k, v in g.items() if k != "ref"}
            mask = images.geometry_mask(g["depth"], g["normal"])
            out = {}
            for f, m, r in configs:
                wpred = workres.WorkingResolution(pred, f if f > 1 else "full", method=m, residual=r, threads=a.threads)
                if i == 0:  # warm-up: the first call of each size pays torch's one-time costs
                    predict_timed(wpred, inp, pred.target)
                img, dt, dc, mb = predict_timed(wpred, inp, pred.target)
                sc = metrics.score(img, g["ref"], mask, with_flip=not a.no_flip)
                row = dict(data=str(d), sample=key, size=f"{g['ref'].shape[1]}x{g['ref'].shape[0]}",
                           config=label(f, m, r), factor=f, psnr=sc["psnr"], ssim=sc["ssim"], flip=sc["flip"],
                           seconds=dt, cpu_seconds=dc, peak_mb=mb, **{f"t_{k}": v for k, v in wpred.last_seconds.items()})
                rows.append(row)
                out[row["config"]] = img
                print(json.dumps(row), file=sys.stderr, flush=True)
            if a.crops and i == 0 and "1/4 bilinear" in out:
                Path(a.crops).mkdir(parents=True, exist_ok=True)
                name = Path(a.crops) / f"{Path(d).name}_{key}.png"
                pick = {k: out[k] for k in ("full", "1/4 bilinear", "1/4 guided", "1/4 guided+direct")}
                xy = crop_sheet(name, pick, g["ref"], out["1/4 bilinear"], out["1/4 guided"])
                print(f"crops: {name} at x,y={xy}: " + " | ".join(list(pick) + ["reference"]), file=sys.stderr)
    print(f"{'data':<14} {'size':>9} {'configuration':<22} {'PSNR':>6} {'SSIM':>6} {'FLIP':>6} {'time s':>7} {'cpu s':>6} {'+MB':>6}")
    seen = []
    for r in rows:
        if "data" not in r:
            continue
        k = (r["data"], r["config"])
        if k in seen:
            continue
        seen.append(k)
        rs = [x for x in rows if (x["data"], x["config"]) == k]
        fl = [x["flip"] for x in rs if x["flip"] is not None]
        print(f"{Path(k[0]).name:<14} {rs[0]['size']:>9} {k[1]:<22} {np.mean([x['psnr'] for x in rs]):6.2f} "
              f"{np.mean([x['ssim'] for x in rs]):6.3f} {np.mean(fl) if fl else float('nan'):6.3f} "
              f"{np.median([x['seconds'] for x in rs]):7.3f} {np.median([x['cpu_seconds'] for x in rs]):6.3f} "
              f"{max(x['peak_mb'] for x in rs):6.0f}")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    main()
