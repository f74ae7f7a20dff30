"""`cli.py demo` (`make demo`): SSGI's main job on one random room, end to end.

    cli.py demo --out out/demo [--seed 7] [--size 240x135] [--ref-samples 128] [--model m.pt] [--json]

1. randomize a room (ssgi_addon/room.py ``build_room(seed)``);
2. render it with SSGI: EEVEE's direct-only passes -> the model -> the SSGI compositor node (ssgi_addon/render.py
   ``RenderSession``, after ``setup_scene``), with the shipped default model models/ssgi_default.pt;
3. render the Cycles reference (ssgi_addon/passes.py ``render_cycles``);
4. write PNGs into --out: eevee_direct.png, ssgi.png, cycles_reference.png and sheet.png (side by side), and
   print the times and the PSNR of EEVEE direct light and of SSGI against Cycles.

Pieces that are missing (no torch, no shipped model, a module not written yet) are skipped; the summary's
``missing`` list and stderr say what was not done and why.
"""
from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from pathlib import Path

import numpy as np

from ...model import cliargs
from ...model.errors import UserError

PNG_NAMES = {"eevee": "eevee_direct.png", "ssgi": "ssgi.png", "ref": "cycles_reference.png"}
TITLES = {"eevee": "EEVEE direct light", "ssgi": "SSGI (EEVEE + learned GI)", "ref": "Cycles reference"}


def log(msg: str) -> None:
    print(f"demo: {msg}", file=sys.stderr, flush=True)


def _optional(name: str, missing: list[str], what: str):
    """Import a package module if it exists; a module that is not written yet goes into ``missing``."""
    from .. import root_package
    full = f"{root_package()}.{name}"
    try:
        return importlib.import_module(full)
    except ModuleNotFoundError as e:
        if e.name != full:
            raise
        missing.append(f"{name.replace('.', '/')}.py ({what}) is not there yet")
        return None


def _timed(times: dict, key: str, fn, *a, **kw):
    t = time.perf_counter()
    r = fn(*a, **kw)
    times[key] = round(time.perf_counter() - t, 3)
    return r


def labelled_sheet(images: list[tuple[str, np.ndarray]], strip: int = 18) -> np.ndarray:
    """uint8 HxWx3 images side by side, each with its title on a strip above it."""
    from PIL import Image, ImageDraw

    h = max(im.shape[0] for _, im in images)
    tiles = []
    for title, im in images:
        tile = Image.new("RGB", (im.shape[1], h + strip), (24, 24, 24))
        tile.paste(Image.fromarray(im), (0, strip))
        ImageDraw.Draw(tile).text((3, 3), title, fill=(235, 235, 235))
        tiles.append(np.asarray(tile))
    gap = np.full((h + strip, 4, 3), 24, np.uint8)
    row = [tiles[0]]
    for t in tiles[1:]:
        row += [gap, t]
    return np.concatenate(row, axis=1)


def _ssgi_render(scene, model: Path, samples: int, missing: list[str], times: dict):
    """Render through the SSGI node; returns (prediction HxWx3, eevee HxWx3) or None when a piece is missing."""
    render = _optional("ssgi_addon.pipeline.render", missing, "the SSGI render path")
    node_ops = _optional("ops.node_ops", missing, "Set up SSGI")
    if render is None or node_ops is None:
        return None
    _timed(times, "setup", node_ops.setup_scene, scene, str(model))
    session = render.RenderSession(scene, [scene.frame_current], model=str(model), write=False, keep_groups=True,
                                   samples=samples)
    t = time.perf_counter()
    session.run()
    times["ssgi_total"] = round(time.perf_counter() - t, 3)
    info = session.results[0]
    for k in ("t_passes", "t_predict", "t_composite"):
        times["ssgi_" + k[2:]] = round(info[k], 3)
    groups = info["groups"]
    return np.asarray(info["prediction"], np.float32)[..., :3], np.asarray(groups["eevee"], np.float32)[..., :3]


def run(args) -> dict:
    import bpy

    from ..runtime import deps

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: is a file, not a folder")
    out.mkdir(parents=True, exist_ok=True)
    missing: list[str] = []
    times: dict[str, float] = {}
    t_start = time.perf_counter()
    w, h = args.size

    room = _optional("ssgi_addon.blender.room", missing, "build_room(seed), the room randomizer")
    passes = _optional("ssgi_addon.blender.passes", missing, "render_gbuffer / render_cycles")
    torch_ok, torch_info = deps.torch_status()
    model = Path(args.model) if args.model else None
    if model is None:
        from .. import root_package
        model = Path(sys.modules[root_package()].__file__).resolve().parent / "models" / "ssgi_default.pt"
    if not torch_ok:
        missing.append(f"PyTorch: {torch_info} (the SSGI prediction needs it)")
    fault = cliargs.model_file_fault(model)
    if fault and args.model:  # a folder, a text file, an image ... named as the model: say what it is
        raise UserError(f"--model {args.model}: {fault}")
    if not model.is_file():
        missing.append(f"the shipped default model {model} is not there yet (train one, or pass --model)")

    summary: dict = {"out": str(out), "seed": args.seed, "size": f"{w}x{h}", "model": str(model) if model.is_file() else None,
                     "files": {}, "times_s": times, "psnr_db": {}, "missing": missing}
    if room is None or passes is None:
        for m in missing:
            log("not done: " + m)
        log("nothing to render without the room randomizer and the pass renderer")
        return summary

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    log(f"randomizing room {args.seed}")
    _timed(times, "room", room.build_room, args.seed, scene)
    passes.set_resolution(scene, w, h)

    imgs: dict[str, np.ndarray] = {}
    if torch_ok and model.is_file():
        log(f"rendering with SSGI at {w}x{h} (model {model.name})")
        r = _ssgi_render(scene, model, args.samples, missing, times)
        if r is not None:
            imgs["ssgi"], imgs["eevee"] = r
    if "eevee" not in imgs:
        log(f"rendering EEVEE direct light at {w}x{h} (no SSGI prediction: see the list at the end)")
        g = _timed(times, "eevee", passes.render_gbuffer, scene, ("eevee",), samples=args.samples)
        imgs["eevee"] = np.asarray(g["eevee"], np.float32)[..., :3]
    if args.ref_samples > 0:
        log(f"rendering the Cycles reference ({args.ref_samples} samples{', denoised' if args.denoise else ''})")
        ref = _timed(times, "cycles", passes.render_cycles, scene, args.ref_samples, seed=args.seed,
                     denoise=args.denoise)
        imgs["ref"] = np.asarray(ref["ref"], np.float32)[..., :3]
    else:
        missing.append("the Cycles reference (skipped: --ref-samples 0)")

    from ...model import metrics
    from ...model.images import srgb8, write_png
    if "ref" in imgs:
        for k in ("eevee", "ssgi"):
            if k in imgs:
                summary["psnr_db"][k] = round(float(metrics.psnr(imgs[k], imgs["ref"])), 3)
    for k, name in PNG_NAMES.items():
        if k in imgs:
            write_png(out / name, srgb8(imgs[k], args.exposure))
            summary["files"][k] = str(out / name)
    sheet = [(TITLES[k] + (f"  {summary['psnr_db'][k]:.2f} dB" if k in summary["psnr_db"] else ""), srgb8(imgs[k], args.exposure))
             for k in ("eevee", "ssgi", "ref") if k in imgs]
    write_png(out / "sheet.png", labelled_sheet(sheet))
    summary["files"]["sheet"] = str(out / "sheet.png")
    times["total"] = round(time.perf_counter() - t_start, 3)

    for k, v in times.items():
        log(f"time {k}: {v:.2f} s")
    for k, v in summary["psnr_db"].items():
        log(f"PSNR {TITLES[k]} vs Cycles: {v:.2f} dB" if math.isfinite(v) else f"PSNR {TITLES[k]}: identical")
    for m in missing:
        log("not done: " + m)
    log(f"wrote {', '.join(Path(f).name for f in summary['files'].values())} into {out}")
    return summary


def register_cli(sub) -> None:
    p = sub.add_parser("demo", help="randomize a room, render it with SSGI and Cycles, write PNGs and PSNR",
                       description="SSGI's main job on one random room: EEVEE direct light, the SSGI prediction "
                                   "(shipped default model) and the Cycles reference as PNGs plus a side-by-side "
                                   "sheet; prints the times and the PSNR against Cycles.")
    p.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    p.add_argument("--seed", type=cliargs.nonnegative_int, default=7, help="room seed (default: 7)")
    p.add_argument("--size", type=cliargs.parse_size, default=cliargs.parse_size("240x135"),
                   help="render size WIDTHxHEIGHT (default: 240x135, the training size)")
    p.add_argument("--samples", type=cliargs.positive_int, default=1, help="EEVEE samples for the passes (default: 1)")
    p.add_argument("--ref-samples", type=cliargs.nonnegative_int, default=128,
                   help="Cycles samples for the reference; 0 skips it (default: 128)")
    p.add_argument("--denoise", action=argparse.BooleanOptionalAction, default=True,
                   help="denoise the Cycles reference with OpenImageDenoise (default: on)")
    p.add_argument("--model", default=None, help="model checkpoint (default: the shipped models/ssgi_default.pt)")
    p.add_argument("--exposure", type=cliargs.positive_float, default=1.0, help="exposure of the PNG previews")
    p.set_defaults(func=run)
