"""The fit stage (Fit to Scene): bake views of an artist's scene, fit a small model to them, report.

    summary = run(FitSceneConfig(blend="shot.blend", out="shot_ssgi.pt", views=24, minutes=15))

1. ``views.make_views`` adds jittered cameras to the open file (ssgi_addon/blender/views.py), which is saved as
   a copy ``MODEL.fit/views-TAG.blend`` (the .blend itself is never written);
2. ``bake_views`` bakes every camera of that copy at the plan's frames (``cli.py bake --scenes``, a child
   process; the baker resumes a half-done folder);
3. ``views.split_views`` holds out views by camera; ``model.learn.fit.fit`` searches the size, drops inputs and
   writes MODEL and its report (bpy-free).

TAG hashes the .blend's bytes and the plan: the same config on an unchanged file reuses the views already
baked; an edited file gets new views. ``data=DIR`` fits views baked before (roles from ``plan``, or: cameras
named ssgi.fit.view_* held out as make_views does). ``minutes`` is the whole budget, bake included.

The "Fit to Scene" operator runs ``cli.py fit --progress`` in a separate process (runtime/ui_jobs.py ``fit``,
through the one child launcher): EEVEE and Cycles renders of the bake must not block Blender's UI, and a GL
abort there cannot take Blender down.
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from ...model import cliargs, files
from ...model.errors import UserError

MIN_FIT_MINUTES = 0.5
# The views' references: 16 spp + OIDN, not the baker's default (raw, up to 4096 spp), to keep the whole fit
# within its 15-minute budget; two seeds agree to 36.8-48.9 dB at this setting (docs/bake.md), far above the
# fitted models' error (25-35 dB).
FIT_REF_SAMPLES = 16


# ------------------------------------------------------------------------------------------------- the stage

@dataclass
class FitSceneConfig:
    """What ``run`` fits; the defaults are those of ``cli.py fit`` and the Fit panel."""
    out: str  # the checkpoint to write (.pt)
    blend: str | None = None  # the scene's .blend (not modified) ...
    data: str | None = None  # ... or views baked before
    plan: dict | str | None = None  # with data: the views_plan.json of that bake (a dict or the file)
    scene: str | None = None  # scene name (None: the file's active scene)
    views: int = 24  # about how many views to bake
    minutes: float = 15.0  # the whole time budget, bake included
    target_psnr: float | None = None  # None: the generic model's + 2 dB, or 30 dB without one
    size: tuple[int, int] | None = None  # views' size (None: views.default_size, 240 wide)
    init: str | None = None  # checkpoint to fine-tune from (None: the shipped model when present)
    drop_tol: float = 0.1  # drop an input pass when the val PSNR without it is at most this much lower (dB)
    ref_samples: int = FIT_REF_SAMPLES  # Cycles samples of the views' references (+ OIDN)
    ladder: list | None = None  # [[name, variant, {overrides}], ...] (None: model.learn.fit.LADDER)
    crop: int | None = None  # training crop (None: FitConfig's)
    min_run_s: float | None = None  # shortest training run worth starting (None: FitConfig's)
    threads: int | None = None  # torch threads
    seed: int = 0
    command: str | None = None  # recorded in the checkpoint

    def check(self) -> None:
        """UserError naming the setting, before any work (nothing is written)."""
        out = Path(self.out).expanduser()
        if out.suffix != ".pt":
            raise UserError(f"--out {self.out}: the model file must end in .pt")
        if not out.resolve().parent.is_dir():
            raise UserError(f"--out {self.out}: folder {out.resolve().parent} does not exist")
        if not self.data and not self.blend:
            raise UserError("give --blend FILE (the scene to fit) or --data DIR (views baked before)")
        if self.views < 4:
            raise UserError(f"--views {self.views}: at least 4 views are needed (training, validation and test views)")
        if not (self.minutes > 0 and math.isfinite(self.minutes)):
            raise UserError(f"--minutes must be > 0 (got {self.minutes})")
        if self.ref_samples < 1:
            raise UserError(f"--ref-samples {self.ref_samples}: must be positive")
        fault = cliargs.model_file_fault(self.init) if self.init else None
        if fault:  # before any baking
            raise UserError(f"--init {self.init}: {fault}")
        if isinstance(self.plan, str) and not Path(self.plan).is_file():
            raise UserError(f"--plan {self.plan}: no such file")
        if self.ladder is not None and not (isinstance(self.ladder, list) and all(
                isinstance(r, (list, tuple)) and len(r) == 3 for r in self.ladder)):
            raise UserError(f"--ladder must be a JSON list of [name, variant, {{overrides}}], got {self.ladder!r}")


def work_dir(out) -> Path:
    """MODEL.fit/ beside the model: the views' .blend copy, the baked views, the plan, the candidates."""
    o = Path(out)
    return o.with_name(o.stem + ".fit")


def run(cfg: FitSceneConfig, progress=None, should_stop=None, log=None) -> dict:
    """Fit a model to a scene (module doc); returns the summary (model.learn.fit.fit's, plus bake_minutes,
    total_minutes, views, init). ``progress(dict)`` gets phase / message / progress; ``should_stop()`` is
    checked by the fit between training steps."""
    from ..blender import views as fviews

    log = log or _stderr
    cfg.check()
    t0 = time.perf_counter()
    out = Path(cfg.out).expanduser().resolve()
    work = work_dir(out)
    report = progress or (lambda d: None)
    bake_s = 0.0
    if cfg.data:
        data_dir = Path(cfg.data)
        plan = cfg.plan if isinstance(cfg.plan, dict) else (
            json.loads(Path(cfg.plan).read_text()) if cfg.plan else fviews.derive_plan(data_dir, cfg.seed))
    else:
        import bpy

        from ..blender.blendfile import check_blend, open_blend, pick_scene
        blend = check_blend(cfg.blend)
        open_blend(blend)
        scene = pick_scene(blend, cfg.scene)
        if bpy.context.window is not None and bpy.context.scene != scene:
            bpy.context.window.scene = scene
        report(dict(phase="views", message="adding jittered cameras", progress=0.0))
        plan = fviews.make_views(scene, cfg.views, cfg.seed)
        size = tuple(cfg.size) if cfg.size else fviews.default_size(scene)
        plan.update(size=list(size), blend=str(blend))
        work.mkdir(parents=True, exist_ok=True)
        # views of THIS file with THESE settings: an edited scene gets new views, an unchanged one resumes
        tag = fviews.views_tag(blend, plan)
        wblend = work / f"views-{tag}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(wblend), copy=True)
        files.write_json(work / "views_plan.json", plan, default=str)
        data_dir = work / f"views-{tag}"
        report(dict(phase="bake", message=f"baking {len(plan['cameras']) * len(plan['frames'])} views", progress=0.0))
        bake_views(wblend, data_dir, plan, size, ref_samples=cfg.ref_samples, log=log)
        bake_s = time.perf_counter() - t0
        log(f"fit: views baked in {bake_s / 60:.2f} min")
    train, val, test = fviews.split_views(data_dir, plan)

    from ...model.learn import fit as mfit
    from ..blender.node import DEFAULT_MODEL
    init = cfg.init or (str(DEFAULT_MODEL) if DEFAULT_MODEL.is_file() else None)
    left = 60.0 * cfg.minutes - (time.perf_counter() - t0)
    floor = max(0.1 * 60.0 * cfg.minutes, 60.0 * MIN_FIT_MINUTES)  # a bake that ate the budget still gets a fit
    fit_minutes = max(left, floor) / 60.0
    if left < floor:
        log(f"fit: the bake took {bake_s / 60:.2f} of {cfg.minutes:g} min; fitting gets {fit_minutes:.2f} min "
            "(the whole fit will run over the budget)")
    mcfg = mfit.FitConfig(data=str(data_dir), out=str(out), train_keys=train, val_keys=val, test_keys=test,
                          minutes=fit_minutes, target_psnr=cfg.target_psnr, init=init, threads=cfg.threads,
                          seed=cfg.seed, drop_tol=cfg.drop_tol, command=cfg.command)
    if cfg.ladder:
        mcfg.ladder = [list(r) for r in cfg.ladder]
    if cfg.crop:
        mcfg.crop = cfg.crop
    if cfg.min_run_s:
        mcfg.min_run_s = cfg.min_run_s
    res = mfit.fit(mcfg, callback=progress, should_stop=should_stop)
    res.update(bake_minutes=bake_s / 60.0, total_minutes=(time.perf_counter() - t0) / 60.0, views=str(data_dir),
               init=init)
    if res.get("report"):  # the bake's share belongs in the report too
        rp = Path(res["report"])
        rep = json.loads(rp.read_text())
        rep.update(bake_minutes=res["bake_minutes"], total_minutes=res["total_minutes"])
        files.write_json(rp, rep, default=str)
    return res


# ------------------------------------------------------------------------------------------------- bake

def bake_views(work_blend, data_dir, plan: dict, size, ref_samples: int | None = FIT_REF_SAMPLES, log=None) -> None:
    """Bake every camera of ``work_blend`` at the plan's frames with the baker (``cli.py bake --scenes``), in
    a child process (the baker resumes a half-done folder). The baker stays in this process's group and dies
    with it (runtime/launcher.py), so cancelling the fit ends the baker too."""
    from ..runtime import launcher
    cmd = launcher.cli_command("bake", "--scenes", str(work_blend), "--frames", ",".join(map(str, plan["frames"])),
                               "--size", f"{size[0]}x{size[1]}", "--out", str(data_dir))
    cmd += ["--ref-samples", str(ref_samples or FIT_REF_SAMPLES), "--denoise"]
    (log or _stderr)(f"fit: baking {len(plan['cameras']) * len(plan['frames'])} views: {' '.join(cmd[1:])}")
    launcher.run(cmd, env=launcher.cli_env(), new_group=False).check("baking the views")


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)
