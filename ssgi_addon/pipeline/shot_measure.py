"""The temporal measure of a shot: every frame of the shot by each method, the converged
reference, and per method the warped flicker (model/infer/temporal.py ``warped_change``) and the PSNR.

    res = measure(scene, frames, model=None, ref_samples=64)   # res["methods"][name] = {warped, psnr, ...}

Methods, per frame at the scene's resolution:
- "SSGI temporal on" / "SSGI temporal off": one RenderSession with the temporal mode on, in frame order; the same
  run gives each frame's stateless prediction, which is the mode off bit for bit (tests/blender/test_temporal.py);
- "EEVEE GI": EEVEE's own render at the scene's settings (ray tracing and fast GI as it sets them: the
  artist-settings render of the same run);
- "Cycles 1 spp + OIDN" and "Cycles N spp + OIDN (equal time)": N is the rung of 1, 2, 4, ... spp whose time on
  the first frame is closest to SSGI's mean per-frame time; Cycles' seed is fixed (Blender's default,
  use_animated_seed off);
- the reference: Cycles ``ref_samples`` spp + OIDN.
The warped flicker is scored on the pixels whose whole bilinear footprint in the frame before is the same
surface (``temporal.valid_mask`` of the G-buffer: depth, normal, albedo agree); the unwarped change of error
(analysis.temporal_change) is given beside it. Used by ``cli.py report --shot`` and benchmarks/temporal.py.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ...model import metrics
from ...model.evaluate.analysis import temporal_change
from ...model.infer import temporal as tp
from ..blender import passes

LADDER = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024)
CYCLES_SEED = 7919  # as the report's ladder (report_run.LADDER_SEED)
KEEP = ("albedo", "depth", "normal", "vector", "rest", "eevee", "direct", "direct_soft")  # + the temporal mode's direct-light guide


def score(imgs, refs, vectors, masks) -> dict:
    """Warped flicker, unwarped change of error, PSNR and tonemapped PSNR over all frames (pooled MSE)."""
    wc = tp.warped_change(imgs, refs, vectors, masks)
    mse = float(np.mean([np.mean((metrics.clean(i) - metrics.clean(r)) ** 2) for i, r in zip(imgs, refs)]))
    tm = float(np.mean([np.mean((metrics.tonemap(metrics.clean(i)) - metrics.tonemap(metrics.clean(r))) ** 2)
                        for i, r in zip(imgs, refs)]))
    return dict(warped=wc["change"], warped_per_step=wc["per_step"], unwarped=temporal_change(imgs, refs)["change"],
                psnr=metrics.psnr_from_mse(mse), tm_psnr=metrics.psnr_from_mse(tm))


def _cycles(scene, frames, spp, seed):
    imgs, ts = [], []
    for f in frames:
        scene.frame_set(f)
        t0 = time.perf_counter()
        imgs.append(passes.render_cycles(scene, spp, seed=seed, denoise=True)["ref"])
        ts.append(time.perf_counter() - t0)
    return imgs, ts


def measure(scene, frames, model=None, ref_samples: int = 64, log=None, keep_images: bool = False,
            equal_time: bool = True) -> dict:
    """The shot's table (see the module docstring). The scene needs an SSGI node (compositor.setup_scene). With
    ``keep_images`` the result also holds "images" {method: [HxWx3]}, "refs", "vectors", "masks", "parts" (the
    stateless diffuse parts) and "groups" (per frame: KEEP), for figures and re-blends."""
    from .render import RenderSession
    log = log or (lambda m: None)
    frames = list(frames)
    s = RenderSession(scene, frames, model=model, write=False, keep_groups=True, temporal="on")
    on, off, parts, groups, eevee, t_ssgi, t_eevee = [], [], [], [], [], [], []
    for info in s.iter_frames():
        on.append(info["prediction"])
        off.append(info["stateless"])
        parts.append(info["stateless_part"])
        groups.append({k: info["groups"][k] for k in KEEP if k in info["groups"]})
        eevee.append(info["groups"]["beauty"][..., :3])
        t_ssgi.append(info["t_total"])
        t_eevee.append(info["t_pass_renders"].get("rest", math.nan))
        log(f"SSGI frame {info['frame']}: {info['t_total']:.2f} s")
    vectors = [g["vector"] for g in groups]
    masks = [None] + [tp.valid_mask(groups[t - 1], groups[t], vectors[t]) for t in range(1, len(frames))]
    t_model = float(np.mean(t_ssgi))
    scene.frame_set(frames[0])
    ladder = []
    for spp in LADDER if equal_time else ():
        t0 = time.perf_counter()
        passes.render_cycles(scene, spp, seed=CYCLES_SEED, denoise=True)
        ladder.append((spp, time.perf_counter() - t0))
        if ladder[-1][1] > t_model:
            break
    eq = min(ladder, key=lambda st: abs(st[1] - t_model))[0] if ladder else 1
    log(f"equal time: {eq} spp (ladder {ladder})")
    c1, t_c1 = _cycles(scene, frames, 1, CYCLES_SEED)
    ceq, t_ceq = _cycles(scene, frames, eq, CYCLES_SEED) if eq != 1 else (c1, t_c1)
    refs, t_ref = _cycles(scene, frames, ref_samples, 1)
    eq_name = f"Cycles {eq} spp + OIDN (equal time)"
    seqs = {"SSGI temporal on": on, "SSGI temporal off": off, "EEVEE GI": eevee, "Cycles 1 spp + OIDN": c1}
    seqs |= {eq_name: ceq} if equal_time else {}
    times = {"SSGI temporal on": t_model, "SSGI temporal off": t_model, "EEVEE GI": float(np.nanmean(t_eevee)),
             "Cycles 1 spp + OIDN": float(np.mean(t_c1)), eq_name: float(np.mean(t_ceq))}
    times = {k: v for k, v in times.items() if k in seqs}
    methods = {k: score(v, refs, vectors, masks) | {"s_per_frame": times[k]} for k, v in seqs.items()}
    on_, off_, c1_ = methods["SSGI temporal on"], methods["SSGI temporal off"], methods["Cycles 1 spp + OIDN"]
    res = dict(scene=scene.name, frames=[frames[0], frames[-1]], n_frames=len(frames),
               size=[scene.render.resolution_x, scene.render.resolution_y], ref_samples=ref_samples,
               ref_s_per_frame=float(np.mean(t_ref)), equal_time_spp=eq, ladder=ladder, window=tp.WINDOW,
               weight=tp.HISTORY_WEIGHT, scored_pixel_share=float(np.mean([m.mean() for m in masks[1:]])),
               cycles_seed=f"fixed ({CYCLES_SEED}) in every frame, Blender's default (use_animated_seed off)",
               methods=methods, bar=dict(flicker_at_most_cycles_1spp=on_["warped"] <= c1_["warped"],
                                         psnr_cost_db=off_["psnr"] - on_["psnr"],
                                         psnr_cost_ok=off_["psnr"] - on_["psnr"] <= 0.3))
    if keep_images:
        res.update(images=seqs, refs=refs, vectors=vectors, masks=masks, parts=parts, groups=groups, target=s.target)
    return res


BUILTIN = "builtin"  # --shot builtin: the default shot built in code (blender/temporal_shot.py)
DEFAULT_SIZE = (160, 90)


def open_shot(shot: str, size=DEFAULT_SIZE, scene_name: str | None = None, model=None):
    """The shot's scene at ``size`` with an SSGI node: ``shot`` a .blend (opened; never written) or BUILTIN."""
    from pathlib import Path

    from ..blender import temporal_shot
    from ..blender.compositor import setup_scene
    if shot == BUILTIN:
        scene = temporal_shot.build_shot(tuple(size))
    else:
        from ..blender.blendfile import open_blend, pick_scene
        open_blend(shot)
        scene = pick_scene(Path(shot), scene_name)
        passes.set_resolution(scene, *size)
    setup_scene(scene, model)
    return scene


def run_shot(shot: str, frames=None, size=DEFAULT_SIZE, model=None, ref_samples: int = 64, log=None) -> dict:
    """``measure`` of a shot (``open_shot``) over ``frames`` (default: its frame range), with the shot's name."""
    scene = open_shot(shot, size, model=model)
    frames = list(frames) if frames else list(range(scene.frame_start, scene.frame_end + 1))
    if len(frames) < 2:
        from ...model.errors import UserError
        raise UserError(f"--shot-frames: the temporal measure needs at least two frames, got {frames}")
    return measure(scene, frames, model=model, ref_samples=ref_samples, log=log) | {"shot": shot}
