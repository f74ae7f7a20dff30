"""Benchmark (issue 15): the working resolution beside emitters. For each .blend scene and model, renders the
frame's passes as the render path does (``RenderSession``, the node's groups, once), then predicts and composes it
at full resolution, at 1/4 with and without the full-resolution prediction near emitters (model/infer/fine.py) and
at 1/2, and scores each against the scene's Cycles reference: over the geometry pixels (the report's PSNR) and per
band of distance (Chebyshev, output pixels) from the nearest emitter pixel, with the mean signed error of each band
and the prediction seconds (reduce + network + upsample + fine), all in the same run.

    .venv/bin/python benchmarks/emitter_rim.py --scenes S/cornell_emissive.blend S/living_room.blend \\
        --refs REPORT/data [--models models/ssgi_one_render.pt models/ssgi_default.pt] [--size 960x540] \\
        [--samples 16] [--json out.json] [--crops DIR]

``--refs``: a folder baked by ``cli.py bake --scenes`` (or a report's OUT/data) at the same size: each scene's
reference is the sample whose ``ssgi_scene`` header names it (the whole image ``ref``; a ref_diffuse model's image
is composed with EEVEE's rest as the node shows it). ``S`` is benchmarks/artist_scenes.py's ``--out``. ``--crops DIR``:
per scene and model, DIR/SCENE_MODEL.png: the emitters' box and 40 px round it, full | 1/4 no fine | 1/4 | reference
above (images.srgb8), 4x |image - reference| below, magnified 2x.
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

CONFIGS = (("full", "full", True), ("1/4", "4x", True), ("1/4 no fine", "4x", False), ("1/2", "2x", True))
BANDS = ((0, 0), (1, 4), (5, 8), (9, 16), (17, 32), (33, None))  # Chebyshev distance from an emitter pixel


def references(folder: Path) -> dict[str, Path]:
    import OpenEXR
    out = {}
    for p in sorted(folder.glob("*.exr")):
        name = OpenEXR.File(str(p)).header().get("ssgi_scene")
        if name:
            out[str(name)] = p
    return out


def frame_groups(blend: Path, model: str, size, samples: int) -> tuple[dict, str]:
    """The node's groups of the file's scene at ``size`` and ``samples`` (RenderSession._passes), and the target."""
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
    tiles = [shown["full"], shown["1/4 no fine"], shown["1/4"], ref]
    top = np.concatenate([images.srgb8(t[y0:y1, x0:x1]) for t in tiles], 1)
    err = [np.clip(np.abs(t - ref)[y0:y1, x0:x1].mean(-1, keepdims=True) * 4, 0, 1).repeat(3, -1) for t in tiles]
    bot = (np.concatenate(err, 1) * 255).astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    images.write_png(path, np.concatenate([top, bot], 0).repeat(2, 0).repeat(2, 1))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", required=True, type=Path)
    ap.add_argument("--refs", required=True, type=Path)
    ap.add_argument("--models", nargs="+", default=["models/ssgi_one_render.pt"])
    ap.add_argument("--size", type=parse_size, default=(960, 540))
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--crops", type=Path)
    a = ap.parse_args(argv)
    refs = references(a.refs)
    rows = []
    for blend in a.scenes:
        if blend.stem not in refs:
            raise UserError(f"--refs {a.refs}: no sample of scene {blend.stem!r} (it has {', '.join(refs) or 'none'})")
        from ssgi.model.dataset import exrio
        ref = exrio.read_sample(refs[blend.stem], strict=False)["ref"][..., :3]
        for model in a.models:
            g, session = frame_groups(blend, model, a.size, a.samples)
            if ref.shape[:2] != g["depth"].shape[:2]:
                raise UserError(f"{refs[blend.stem]}: the reference is {ref.shape[1]}x{ref.shape[0]}, not {a.size[0]}x{a.size[1]}")
            inner = session.predictor.inner
            mask = images.geometry_mask(g["depth"], g["normal"])
            em = np.asarray(g.get("emission", np.zeros_like(ref)))
            dist = fine_mod.chebyshev_distance(em.max(-1) > fine_mod.FINE_EMISSION, 33)
            clamp = lambda x: np.clip(x, 0, 1)  # noqa: E731  (the report's PSNR: values clamped to [0, 1])
            shown = {}
            for label, setting, use_fine in CONFIGS:
                w = WorkingResolution(inner, setting, fine=use_fine)
                w.predict(g)  # warm
                t = time.perf_counter()
                pred = w.predict(g)
                secs = time.perf_counter() - t
                img = shown[label] = compose(pred, g, inner.target)
                row = dict(scene=blend.stem, model=Path(model).name, config=label, seconds=secs,
                           fine_pixels=int(getattr(w, "last_fine_pixels", 0)),
                           psnr=metrics.score(img, ref, mask, with_ssim=False, with_flip=False)["psnr"], bands=[])
                for lo, hi in BANDS:
                    b = mask & (dist >= lo) & (dist <= (hi if hi is not None else 1 << 30))
                    if b.any():
                        row["bands"].append(dict(band=f"{lo}-{hi if hi is not None else ''}", pixels=int(b.sum()),
                                                 sse=float(((clamp(img) - clamp(ref)) ** 2)[b].sum()),
                                                 mean_error=float((img - ref)[b].mean()), mean_ref=float(ref[b].mean())))
                rows.append(row)
                print(f"{row['scene']:18s} {row['model']:22s} {label:12s} PSNR {row['psnr']:6.2f}  {secs:6.3f} s  "
                      f"fine px {row['fine_pixels']:7d}  " + "  ".join(
                          f"[{b['band']}] sse {b['sse']:7.1f} err {b['mean_error']:+.3f}" for b in row["bands"][:4]),
                      flush=True)
            if a.crops and (dist == 0).any():
                crop_sheet(a.crops / f"{blend.stem}_{Path(model).stem}.png", shown, ref, dist == 0)
    if a.json:
        a.json.write_text(json.dumps(dict(command=" ".join(sys.argv), size=list(a.size), samples=a.samples,
                                          bands=[list(b) for b in BANDS], rows=rows), indent=1))
    return 0


if __name__ == "__main__":
    _bootstrap.run_main(main)
