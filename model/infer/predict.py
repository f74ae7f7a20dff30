"""Run a model on one sample file (``cli.py predict``, bpy-free).

The output EXR is a plain RGB float EXR (channels R, G, B: linear HDR radiance) that any viewer opens.
``--png`` also writes a preview: Reinhard tonemap x/(1+x) after an exposure scale, then the sRGB transfer
curve, 8 bit. When the sample holds a reference (``ref``), the PSNR of the prediction is reported.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .. import channels as ch, images
from ..dataset import exrio
from .. import metrics
from ..errors import UserError


def write_rgb_exr(path, rgb: np.ndarray, half: bool = False) -> None:
    exrio.write_exr(path, {c: rgb[..., i] for i, c in enumerate("RGB")}, half=half)


def predict_file(model, input_path, out, png=None, threads=None, tile=None, runtime="auto", device="auto",
                 working_res="full") -> dict:
    from .predictor import DEFAULT_TILE, load_predictor
    from .workres import WorkingResolution

    pred = WorkingResolution(load_predictor(model, num_threads=threads, tile=tile or DEFAULT_TILE, runtime=runtime,
                                            device=device), working_res)
    input_path = Path(input_path)
    planes, _ = exrio.read_exr(input_path)
    lacking = [c for g in pred.required for c in ch.GROUPS[g].channels if c not in planes]
    if lacking:
        raise UserError(f"{input_path}: missing channel(s) {', '.join(lacking)}, which model {model} "
                        f"(inputs {ch.format_spec(pred.spec)}) needs")
    present = tuple(g for g, grp in ch.GROUPS.items() if all(c in planes for c in grp.channels))
    groups = exrio.read_sample(input_path, present, strict=False)
    t = time.perf_counter()
    rgb = pred.predict({g: a for g, a in groups.items() if g in pred.required or g in ("depth", "normal", "albedo")})
    dt = time.perf_counter() - t
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    write_rgb_exr(out, rgb)
    res = dict(out=str(out), size=list(rgb.shape[:2]), seconds=dt, repaired_pixels=pred.last_repaired,
               model=str(model), inputs=ch.format_spec(pred.spec), runtime=pred.runtime, device=pred.device,
               model_file=str(pred.path), working_factor=pred.last_factor)
    if ch.TARGET_GROUP in groups:
        ref = groups[ch.TARGET_GROUP]
        if np.isfinite(ref).all():
            res.update(psnr=metrics.psnr(rgb, ref), tm_psnr=metrics.tm_psnr(rgb, ref), ssim=metrics.ssim(rgb, ref))
    if png:
        images.write_png(png, images.srgb8(rgb))
        res["png"] = str(png)
    if not np.isfinite(rgb).all():  # cannot happen by construction; a loud guard
        raise UserError(f"{model}: produced a non-finite prediction for {input_path}")
    return res
