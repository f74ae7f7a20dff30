"""The demo stage (`cli.py demo`, `make demo`): SSGI's main job on one random room, end to end.

    summary = run(DemoConfig(out="out/demo", seed=7, size=(240, 135), ref_samples=128))

1. randomize a room (ssgi_addon/blender/room.py ``build_room(seed)``);
2. render it with SSGI: the passes the model reads -> the model -> the SSGI compositor node (pipeline/render.py
   ``RenderSession``, after blender/compositor.py ``setup_scene``), with the shipped default model
   models/ssgi_default.pt, and take the frame the node shows;
3. render what costs about the same, for comparison: EEVEE's own render with ray tracing and fast GI at the same
   samples (pipeline/report_run.py ``render_eevee_gi``) and Cycles 1 sample + OpenImageDenoise;
4. render the Cycles reference (blender/passes.py ``render_cycles``);
5. write PNGs into ``out``: eevee_gi.png, ssgi.png, cycles_1spp_oidn.png, cycles_reference.png and sheet.png
   (side by side, each titled with its PSNR and seconds), and print each image's seconds and PSNR against the
   reference.

Pieces that are missing (no torch, no shipped model) are skipped; the summary's ``missing`` list and stderr
say what was not done and why.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...model import cliargs
from ...model.errors import UserError

PNG_NAMES = {"eevee_gi": "eevee_gi.png", "ssgi": "ssgi.png", "cycles_1spp_oidn": "cycles_1spp_oidn.png",
             "ref": "cycles_reference.png"}
TITLES = {"eevee_gi": "EEVEE GI", "ssgi": "SSGI", "cycles_1spp_oidn": "Cycles 1 spp + OIDN", "ref": "Cycles reference"}
COMPARED = ("eevee_gi", "ssgi", "cycles_1spp_oidn")  # scored against the reference, in the sheet's order
LADDER_SEED = 7919  # Cycles seed of the 1-sample render: not the reference's (the room seed)


@dataclass
class DemoConfig:
    """What ``run`` renders; the defaults are those of ``cli.py demo``."""
    out: str = "out/demo"  # output folder
    seed: int = 7  # room seed
    size: tuple[int, int] = (240, 135)  # render size (the training size)
    samples: int = 1  # EEVEE samples of the SSGI passes and of EEVEE's own GI render
    ref_samples: int = 128  # Cycles samples for the reference; 0 skips it
    denoise: bool = True  # denoise the Cycles reference with OpenImageDenoise
    model: str | None = None  # a shipped model's name or a checkpoint (None: the shipped default)
    exposure: float = 1.0  # exposure of the PNG previews

    def check(self) -> None:
        out = Path(self.out)
        if out.exists() and not out.is_dir():
            raise UserError(f"--out {out}: is a file, not a folder")
        if self.seed < 0:
            raise UserError(f"--seed {self.seed}: must be >= 0")
        if min(self.size) < 1 or self.samples < 1 or self.ref_samples < 0 or not self.exposure > 0:
            raise UserError(f"size {self.size}, samples {self.samples}, ref_samples {self.ref_samples}, exposure "
                            f"{self.exposure}: size and samples must be positive, ref_samples >= 0, exposure > 0")
        fault = cliargs.model_file_fault(cliargs.model_arg(self.model)) if self.model else None
        if fault:  # a folder, a text file, an image ... named as the model: say what it is, before any work
            raise UserError(f"--model {self.model}: {fault}")


def log(msg: str) -> None:
    print(f"demo: {msg}", file=sys.stderr, flush=True)


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


def _ssgi_render(scene, model: Path, samples: int, times: dict) -> np.ndarray:
    """Render through the SSGI node; returns the frame the node shows (HxWx3 linear)."""
    from ..blender.compositor import setup_scene
    from . import render

    _timed(times, "setup", setup_scene, scene, str(model))
    session = render.RenderSession(scene, [scene.frame_current], model=str(model), write=False, keep_groups=True,
                                   samples=samples)
    t = time.perf_counter()
    session.run()
    times["ssgi"] = round(time.perf_counter() - t, 3)
    info = session.results[0]
    for k in ("t_passes", "t_predict", "t_composite"):
        times["ssgi_" + k[2:]] = round(info[k], 3)
    return np.asarray(info["prediction"], np.float32)[..., :3]


def _title(key: str, psnr: float | None, seconds: float | None) -> str:
    """A sheet tile's title: the image's name, its PSNR against the reference and its render seconds."""
    parts = [TITLES[key]]
    if psnr is not None and math.isfinite(psnr):
        parts.append(f"{psnr:.2f} dB")
    if seconds is not None:
        parts.append(f"{seconds:.1f} s")
    return "  ".join(parts)


def run(cfg: DemoConfig) -> dict:
    """Render the demo (module doc); returns the summary: out, seed, size, model, files, times_s, psnr_db,
    missing."""
    import bpy

    from ..blender import node, passes, room
    from ..blender.scene_state import preserved
    from ..runtime import deps
    from .report_run import render_eevee_gi

    cfg.check()
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    missing: list[str] = []
    times: dict[str, float] = {}
    t_start = time.perf_counter()
    w, h = cfg.size

    torch_ok, torch_info = deps.torch_status()
    model = Path(cliargs.model_arg(cfg.model)) if cfg.model else node.DEFAULT_MODEL
    from ...model.infer import onnx as ort_backend
    ort_ok = model.is_file() and ort_backend.available() and ort_backend.export_of(model) is not None
    if not torch_ok and not ort_ok:
        missing.append(f"PyTorch: {torch_info} (the SSGI prediction needs it, or onnxruntime and the model's "
                       f"ONNX export beside it)")
    if not model.is_file():  # only the shipped default can be missing here: check() refused a bad --model
        missing.append(f"the shipped default model {model} is not there yet (train one, or pass --model)")

    summary: dict = {"out": str(out), "seed": cfg.seed, "size": f"{w}x{h}", "model": str(model) if model.is_file() else None,
                     "files": {}, "times_s": times, "psnr_db": {}, "missing": missing}

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    log(f"randomizing room {cfg.seed}")
    _timed(times, "room", room.build_room, cfg.seed, scene)
    passes.set_resolution(scene, w, h)

    imgs: dict[str, np.ndarray] = {}
    if (torch_ok or ort_ok) and model.is_file():
        log(f"rendering with SSGI at {w}x{h} (model {model.name})")
        imgs["ssgi"] = _ssgi_render(scene, model, cfg.samples, times)
    log(f"rendering EEVEE with ray tracing and fast GI ({cfg.samples} sample{'s' * (cfg.samples != 1)})")
    with preserved(scene):
        imgs["eevee_gi"] = _timed(times, "eevee_gi", render_eevee_gi, scene, "default", cfg.samples)
    log("rendering Cycles 1 sample + OpenImageDenoise")
    with preserved(scene):
        imgs["cycles_1spp_oidn"] = _timed(times, "cycles_1spp_oidn", passes.render_cycles, scene, 1,
                                          seed=LADDER_SEED, denoise=True)["ref"][..., :3]
    if cfg.ref_samples > 0:
        log(f"rendering the Cycles reference ({cfg.ref_samples} samples{', denoised' if cfg.denoise else ''})")
        with preserved(scene):
            ref = _timed(times, "cycles", passes.render_cycles, scene, cfg.ref_samples, seed=cfg.seed,
                         denoise=cfg.denoise)
        imgs["ref"] = np.asarray(ref["ref"], np.float32)[..., :3]
    else:
        missing.append("the Cycles reference and the PSNRs (skipped: --ref-samples 0)")
    imgs = {k: np.asarray(v, np.float32) for k, v in imgs.items()}

    from ...model import metrics
    from ...model.images import srgb8, write_png
    if "ref" in imgs:
        for k in COMPARED:
            if k in imgs:
                summary["psnr_db"][k] = round(float(metrics.psnr(imgs[k], imgs["ref"])), 3)
    for k, name in PNG_NAMES.items():
        if k in imgs:
            write_png(out / name, srgb8(imgs[k], cfg.exposure))
            summary["files"][k] = str(out / name)
    sheet = [(_title(k, summary["psnr_db"].get(k), times.get("cycles" if k == "ref" else k)),
              srgb8(imgs[k], cfg.exposure)) for k in (*COMPARED, "ref") if k in imgs]
    write_png(out / "sheet.png", labelled_sheet(sheet))
    summary["files"]["sheet"] = str(out / "sheet.png")
    times["total"] = round(time.perf_counter() - t_start, 3)

    for k, v in times.items():
        log(f"time {k}: {v:.2f} s")
    for k, v in summary["psnr_db"].items():
        log(f"PSNR {TITLES[k]} vs the reference: {v:.2f} dB in {times[k]:.2f} s" if math.isfinite(v)
            else f"PSNR {TITLES[k]}: identical to the reference")
    for m in missing:
        log("not done: " + m)
    log(f"wrote {', '.join(Path(f).name for f in summary['files'].values())} into {out}")
    return summary
