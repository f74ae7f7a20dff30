"""Benchmark: the working resolution on .blend scenes at an artist size. For each scene and model, renders
the frame's passes as the render path does (``RenderSession``, the node's groups, once), then predicts and composes
it at full resolution, at 1/4 with and without the full-resolution prediction near emitters (model/infer/fine.py) and
at 1/2, and scores each against the scene's Cycles reference: PSNR, SSIM and FLIP over the geometry pixels (as the
report scores, ``metrics.score``), the squared error and mean signed error per band of distance (Chebyshev, output
pixels) from the nearest emitter pixel, and the prediction's seconds (reduce + network + upsample + fine, after one
untimed run), all in the same run.

    .venv/bin/python benchmarks/working_res_scenes.py --scenes S/*.blend --refs REPORT/data [MORE/data ...] \\
        [--models models/ssgi_one_render.pt models/ssgi_default.pt] [--size 960x540] [--samples 16] \\
        [--configs full 1/4 "1/4 no fine" 1/2] [--no-flip] [--json out.json] [--crops DIR]

``--refs``: folders baked by ``cli.py bake --scenes`` (or a report's OUT/data) at the same size: each scene's
reference is the sample whose manifest entry names it (the whole image ``ref``; a ref_diffuse model's image
is composed with EEVEE's rest as the node shows it). ``S`` is scenes/artist.py's ``--out``. ``--crops DIR``:
per scene with an emitter and model, DIR/SCENE_MODEL.png: the emitters' box and 40 px round it, full | 1/4 no fine |
1/4 | reference above (images.srgb8), 4x |image - reference| below, magnified 2x. Ends with each model and
configuration's mean over the scenes.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import _bootstrap  # (the checkout as package ssgi)
import bpy
import numpy as np

from ssgi.model import images, metrics
from ssgi.model.cliargs import parse_size
from ssgi.model.errors import UserError
from ssgi.model.infer import fine as fine_mod
from ssgi.model.infer.compose import compose
from ssgi.model.infer.workres import WorkingResolution

CONFIGS = {"full": ("full", True), "1/4": ("4x", True), "1/4 no fine": ("4x", False), "1/2": ("2x", True)}
BANDS = ((0, 0), (1, 4), (5, 8), (9, 16), (17, 32), (33, None))  # Chebyshev distance from an emitter pixel


def references(folders) -> dict[str, Path]:
    """{scene name: the sample of the folders whose manifest entry names it} (the first found)."""
    from ssgi.model.dataset import folder as dataset
    out = {}
    for d in folders:
        for key, s in sorted(dataset.open_folder(d, scenes=True)["samples"].items()):
            out.setdefault(str(s["scene"]), dataset.sample_path(d, key))
    return out


def frame_groups(blend: Path, model: str, size, samples: int):
    """The node's groups of the file's scene at ``size`` and ``samples`` (RenderSession._passes), and the session."""
    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    from ssgi.ssgi_addon.blender.scene_state import preserved
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    sc = bpy.context.scene
    passes.set_resolution(sc, *size)
    sc.eevee.taa_render_samples = samples
    setup_scene(sc, model)
    s = RenderSession(sc, model=model, write=False, keep_groups=True, working_res="full")
    with preserved(sc):
        return s._passes(), s


def crop_sheet(path: Path, shown: dict, ref: np.ndarray, hot: np.ndarray, pad: int = 40) -> None:
    ys, xs = np.nonzero(hot)
    y0, y1 = max(0, ys.min() - pad), min(hot.shape[0], ys.max() + 1 + pad)
    x0, x1 = max(0, xs.min() - pad), min(hot.shape[1], xs.max() + 1 + pad)
    tiles = [shown[k] for k in ("full", "1/4 no fine", "1/4") if k in shown] + [ref]
    top = np.concatenate([images.srgb8(t[y0:y1, x0:x1]) for t in tiles], 1)
    err = [np.clip(np.abs(t - ref)[y0:y1, x0:x1].mean(-1, keepdims=True) * 4, 0, 1).repeat(3, -1) for t in tiles]
    bot = (np.concatenate(err, 1) * 255).astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    images.write_png(path, np.concatenate([top, bot], 0).repeat(2, 0).repeat(2, 1))


def score_scene(blend: Path, ref: np.ndarray, model: str, a) -> list[dict]:
    g, session = frame_groups(blend, model, a.size, a.samples)
    if ref.shape[:2] != g["depth"].shape[:2]:
        raise UserError(f"{blend.stem}: the reference is {ref.shape[1]}x{ref.shape[0]}, not {a.size[0]}x{a.size[1]}")
    inner = session.predictor.inner
    mask = images.geometry_mask(g["depth"], g["normal"])
    em = np.asarray(g.get("emission", np.zeros_like(ref)))
    dist = fine_mod.chebyshev_distance(em.max(-1) > fine_mod.FINE_EMISSION, 33)
    clamp = lambda x: np.clip(x, 0, 1)  # noqa: E731  (the report's PSNR: values clamped to [0, 1])
    rows, shown = [], {}
    for label in a.configs:
        setting, use_fine = CONFIGS[label]
        w = WorkingResolution(inner, setting, fine=use_fine)
        w.predict(g)  # untimed: the first call of a size pays torch's one-time costs
        t = time.perf_counter()
        pred = w.predict(g)
        secs = time.perf_counter() - t
        img = shown[label] = compose(pred, g, inner.target)
        sc = metrics.score(img, ref, mask, with_flip=not a.no_flip)
        row = dict(scene=blend.stem, model=Path(model).name, config=label, factor=w.last_factor, seconds=secs,
                   fine_pixels=int(w.last_fine_pixels), psnr=sc["psnr"], ssim=sc["ssim"], flip=sc["flip"], bands=[])
        for lo, hi in BANDS:
            b = mask & (dist >= lo) & (dist <= (hi if hi is not None else 1 << 30))
            if b.any():
                row["bands"].append(dict(band=f"{lo}-{hi if hi is not None else ''}", pixels=int(b.sum()),
                                         sse=float(((clamp(img) - clamp(ref)) ** 2)[b].sum()),
                                         mean_error=float((img - ref)[b].mean()), mean_ref=float(ref[b].mean())))
        rows.append(row)
        print(f"{row['scene']:18s} {row['model']:22s} {label:12s} PSNR {row['psnr']:6.2f} SSIM {row['ssim']:.3f} "
              f"FLIP {row['flip'] if row['flip'] is not None else float('nan'):.3f}  {secs:6.3f} s  fine px "
              f"{row['fine_pixels']:7d}  " + "  ".join(f"[{b['band']}] sse {b['sse']:7.1f} err {b['mean_error']:+.3f}"
                                                       for b in row["bands"][:3] if b["band"] != "33-"), flush=True)
    if a.crops and (dist == 0).any():
        crop_sheet(a.crops / f"{blend.stem}_{Path(model).stem}.png", shown, ref, dist == 0)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", required=True, type=Path)
    ap.add_argument("--refs", nargs="+", required=True, type=Path)
    ap.add_argument("--models", nargs="+", default=["models/ssgi_one_render.pt"])
    ap.add_argument("--size", type=parse_size, default=(960, 540))
    ap.add_argument("--samples", type=int, default=16, help="EEVEE samples of the frame's passes (16)")
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    ap.add_argument("--no-flip", action="store_true", help="skip FLIP (slow at 1080p)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--crops", type=Path)
    a = ap.parse_args(argv)
    refs = references(a.refs)
    rows = []
    from ssgi.model.dataset import exrio
    for blend in a.scenes:
        if blend.stem not in refs:
            raise UserError(f"--refs: no sample of scene {blend.stem!r} (they hold {', '.join(refs) or 'none'})")
        ref = exrio.read_sample(refs[blend.stem], strict=False)["ref"][..., :3]
        for model in a.models:
            rows += score_scene(blend, ref, model, a)
    print("mean over the scenes:")
    for model in dict.fromkeys(r["model"] for r in rows):
        for label in a.configs:
            rs = [r for r in rows if r["model"] == model and r["config"] == label]
            fl = [r["flip"] for r in rs if r["flip"] is not None]
            print(f"  {model:22s} {label:12s} PSNR {np.mean([r['psnr'] for r in rs]):6.2f} SSIM "
                  f"{np.mean([r['ssim'] for r in rs]):.3f} FLIP {np.mean(fl) if fl else float('nan'):.3f} "
                  f"time (median) {np.median([r['seconds'] for r in rs]):.3f} s")
    if a.json:
        a.json.write_text(json.dumps(dict(command=" ".join(sys.argv), size=list(a.size), samples=a.samples,
                                          bands=[list(b) for b in BANDS], rows=rows), indent=1))
    return 0


if __name__ == "__main__":
    _bootstrap.run_main(main)
