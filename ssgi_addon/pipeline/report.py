"""The report stage: speed against error, every method on the same scenes, timed.

    summary = run(ReportConfig(models=["a.pt", "b.pt"], out="out/report", data="dataset/"))
    summary = run(ReportConfig(models=[...], out=..., scenes=["shot.blend"], size=(240, 135)))

Evaluates every method (report_run.py ``ReportRun``) on the validation scenes of a dataset (report_scenes.py
``dataset_scenes``), or on .blend files baked first into OUT/data with the baker (each camera at the current
frame; every sample evaluated), and writes OUT/report.md, OUT/report.json, OUT/pareto.png and
OUT/examples.png (model/evaluate/report.py). While it runs, OUT/report.partial.json holds the numbers of
the scenes done so far. ``cli.py report`` is its command line; the "Report" button runs that command in a
background process.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from ...model.errors import UserError


@dataclass
class ReportConfig:
    """What ``run`` evaluates; the defaults are those of ``cli.py report`` and the Report panel."""
    models: list  # model checkpoints: the network sizes and the linear baseline
    out: str  # output folder
    data: str | None = None  # a dataset folder (its validation scenes are evaluated) ...
    scenes: list | None = None  # ... or .blend files, baked first into OUT/data
    max_scenes: int = 6  # evaluate at most this many scenes
    split: str = "val"  # dataset scenes to evaluate: "val" (the validation split) or "all"
    spp: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64, 128)  # the Cycles ladder
    size: tuple[int, int] | None = None  # bake size with scenes (None: the baker's); a dataset's own otherwise
    ref_samples: int | None = None  # reference samples with scenes, + OIDN (None: the baker's denoised 64)
    reference_scenes: int = 1  # re-render the reference (another seed) on this many scenes, for its time
    eevee_samples: int = 64  # EEVEE GI render samples, default quality (Blender's default)
    eevee_high_samples: int = 64  # EEVEE GI render samples, high quality
    ssgi_samples: int = 16  # EEVEE samples of the SSGI path's passes (G-buffer and rest) for diffuse-part models
    sizes: tuple[str, ...] = ("240x135", "960x540", "1920x1080")  # the scaling measurements' sizes
    scaling: bool = True  # measure the scaling
    temporal_frames: int = 4  # frames of the camera move for temporal stability (0 or 1 skips it)
    temporal_ref_samples: int | None = None  # reference samples per frame of it (None: the dataset's)
    shot: str | None = None  # a shot .blend (or "builtin") for the warped flicker measure (shot_measure.py)
    shot_frames: tuple | None = None  # its frames (None: its frame range)
    shot_size: tuple[int, int] = (160, 90)  # its resolution
    threads: int = 1  # torch threads for the predictions (the add-on's default)
    working_res: str = "auto"  # the network's resolution, as the node's setting (model/infer/workres.py)
    fit_baseline: bool = True  # with data and no linear model among models, fit one (closed form, seconds)
    command: str | None = None  # recorded in report.json

    def check(self) -> None:
        """UserError naming the setting, before any work."""
        if not self.data and not self.scenes:
            raise UserError("give --data DIR (a dataset's validation scenes) or --scenes FILE.blend ...")
        if not self.models:
            raise UserError("--models: give at least one model checkpoint")
        for m in self.models:
            if not Path(m).is_file():
                raise UserError(f"--models {m}: no such file")
        if self.data and not Path(self.data).is_dir():
            raise UserError(f"--data {self.data}: no such folder")
        for s in self.scenes or ():
            if not Path(s).is_file():
                raise UserError(f"--scenes {s}: no such file")
        if self.split not in ("val", "all"):
            raise UserError(f"--split {self.split!r}: choose val or all")
        spp = list(self.spp)
        if not spp or any(int(v) < 1 for v in spp) or len(set(spp)) != len(spp) or spp != sorted(spp):
            raise UserError(f"--spp {','.join(map(str, spp))}: give distinct sample counts >= 1 in ascending order")
        for name in ("max_scenes", "eevee_samples", "eevee_high_samples", "ssgi_samples", "threads"):
            if int(getattr(self, name)) < 1:
                raise UserError(f"--{name.replace('_', '-')} {getattr(self, name)}: must be >= 1")
        for name in ("reference_scenes", "temporal_frames"):
            if int(getattr(self, name)) < 0:
                raise UserError(f"--{name.replace('_', '-')} {getattr(self, name)}: must be >= 0")
        from ...model.infer.workres import parse_setting
        try:
            parse_setting(self.working_res)
        except UserError as e:
            raise UserError(f"--working-res: {e}") from None
        if self.shot and self.shot != "builtin" and not Path(self.shot).is_file():
            raise UserError(f"--shot {self.shot}: no such file (or 'builtin' for the shot built in code)")
        if self.shot_frames is not None and len(self.shot_frames) < 2:
            raise UserError("--shot-frames: give at least two frames")
        if self.scaling and not self.sizes:
            raise UserError("--sizes: give at least one size (or turn the scaling off: --no-scaling)")


def out_dir(text) -> Path:
    """The output folder, created; UserError when it is a file or cannot be written."""
    out = Path(text).expanduser()
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"--out {out}: cannot create the folder ({e.strerror})") from None
    if not os.access(out, os.W_OK):
        raise UserError(f"--out {out}: the folder is not writable")
    return out


def default_model_key(keys_paths) -> str | None:
    """The shipped default model (models/ssgi_default.pt) when it is among the models, else the first network."""
    from ..blender.node import DEFAULT_MODEL
    for key, path, kind in keys_paths:
        if Path(path).resolve() == DEFAULT_MODEL.resolve():
            return key
    return next((key for key, _, kind in keys_paths if kind != "linear"), None)


def _bake_scenes(cfg: ReportConfig, out: Path):
    """``scenes``: bake the .blend files with the baker (bake --scenes: each scene camera at its current frame)
    into OUT/data (resumable), then evaluate every sample of it."""
    from . import bake
    from ..blender.reference import DENOISED_REF_SAMPLES
    from .report_run import log
    from .report_scenes import dataset_scenes

    data = out / "data"
    size = tuple(cfg.size) if cfg.size else bake.DEFAULT_SIZE
    t = time.perf_counter()
    log(f"baking {len(cfg.scenes)} .blend file(s) into {data} (cli.py bake --scenes)")
    res = bake.run(bake.BakeConfig(out=str(data), scenes=[str(p) for p in cfg.scenes], size=size,
                                   ref_samples=cfg.ref_samples or DENOISED_REF_SAMPLES, denoise=True),
                   progress=lambda info: log(f"bake {info['done']}/{info['todo']}: {info}"))
    scenes, over, notes = dataset_scenes(data, (), cfg.max_scenes, "all", per_sample=True)
    notes.append(f"--scenes: baked by ssgi_addon/pipeline/bake.py into {data} ({res['baked']} baked, {res['skipped']} already "
                 f"there, {time.perf_counter() - t:.1f} s); every sample evaluated")
    return scenes, dict(over, source="--scenes " + " ".join(str(p) for p in cfg.scenes)), notes


def run(cfg: ReportConfig, progress=None, should_stop=None) -> dict:
    """Evaluate and write the report (module doc); returns the summary: out, files, scenes, methods (label,
    psnr, whole_s, own_s), default_model, run_s (and default_speedup). ``progress(dict)`` after each step;
    ``should_stop()`` between scenes: the summary then says ``cancelled`` and report.partial.json stays."""
    import bpy

    from ...model.infer import predictor
    from ...model.evaluate import record, report as rep
    from .report_run import ReportRun, Settings, log
    from .report_scenes import dataset_scenes

    cfg.check()
    t_start = time.perf_counter()
    out = out_dir(cfg.out)
    machine = record.machine()
    notes: list[str] = []
    models = [Path(p) for p in cfg.models]
    preds = [(p, predictor.load_predictor(p, num_threads=cfg.threads, runtime="torch")) for p in models]
    if cfg.data and cfg.fit_baseline and not any(pr.kind == "linear" for _, pr in preds):
        from ...model.learn import baseline
        bl = out / "linear_baseline.pt"
        log(f"no linear model given: fitting the linear-regression baseline on {cfg.data} -> {bl}")
        baseline.run_baseline(cfg.data, bl, log=log)
        preds.append((bl, predictor.load_predictor(bl, num_threads=cfg.threads, runtime="torch")))
        notes.append(f"the linear baseline was fitted by this run (model/learn/baseline.py, closed form) on the training "
                     f"split of {cfg.data}: {bl}")
    from ...model.infer.workres import WorkingResolution
    preds = [(p, WorkingResolution(pr, cfg.working_res)) for p, pr in preds]
    n_net = sum(1 for _, pr in preds if pr.kind != "linear")
    if n_net < 3:
        notes.append(f"only {n_net} network size(s) given; the report wants at least 3 (small to large)")

    if cfg.scenes:
        scenes, over, n2 = _bake_scenes(cfg, out)
    else:
        if cfg.size or cfg.ref_samples:
            notes.append("--size and --ref-samples are ignored with --data: the dataset's own settings are used")
        scenes, over, n2 = dataset_scenes(cfg.data, [pr.ckpt for _, pr in preds], cfg.max_scenes, cfg.split)
    notes += n2
    settings = Settings(spp=tuple(cfg.spp), eevee_samples=cfg.eevee_samples,
                        eevee_high_samples=cfg.eevee_high_samples, ssgi_samples=cfg.ssgi_samples,
                        reference_scenes=min(cfg.reference_scenes, len(scenes)), threads=cfg.threads,
                        sizes=tuple(cfg.sizes), temporal_frames=cfg.temporal_frames,
                        temporal_ref_samples=cfg.temporal_ref_samples or over["ref_samples"], **over)
    log(f"{len(scenes)} scene(s) at {settings.size[0]}x{settings.size[1]}, {len(preds)} model(s), "
        f"Cycles ladder {','.join(map(str, settings.spp))} spp")

    partial = out / "report.partial.json"
    runner = ReportRun(scenes, preds, settings, partial=lambda raw: record.write_json(partial, raw),
                       progress=progress, should_stop=should_stop)
    raw, images = runner.run()
    if runner.cancelled:
        return dict(out=str(out), files={}, scenes=raw["scenes"], cancelled=True, partial=str(partial),
                    run_s=time.perf_counter() - t_start)
    keys = [(k, p, pr.kind) for k, (p, pr) in runner._model_keys.items()]
    raw["default_model_key"] = default_model_key(keys)
    if cfg.scaling:
        raw["scaling"] = runner.scaling(scenes[0], settings.sizes)
    if cfg.temporal_frames >= 2:
        raw["temporal"] = runner.temporal(scenes[0], raw["default_model_key"], cfg.temporal_frames)
    if cfg.shot:  # last: it opens the shot's file in place of the scenes
        from . import shot_measure
        key = raw["default_model_key"]
        model = runner._model_keys[key][0] if key in runner._model_keys else None
        raw["temporal_shot"] = shot_measure.run_shot(cfg.shot, cfg.shot_frames, cfg.shot_size, model,
                                                     settings.temporal_ref_samples, log=log)
    machine["loadavg_end"] = list(os.getloadavg())
    raw.update(date=record.now(), command=cfg.command or "ssgi_addon.pipeline.report.run", machine=machine,
               versions=dict(record.versions(), blender=bpy.app.version_string), settings=settings.as_dict(),
               run_s=time.perf_counter() - t_start)
    raw["notes"] = raw.get("notes", []) + notes
    files = rep.write_outputs(raw, images, out)
    if partial.exists():
        partial.unlink()
    log(f"wrote {', '.join(files.values())} in {(time.perf_counter() - t_start) / 60:.1f} min")
    dk = raw.get("default_model_key")
    summ = {k: dict(label=m["label"], psnr=m["summary"].get("psnr"), whole_s=m["summary"].get("whole_s"),
                    own_s=m["summary"].get("own_s"))
            for k, m in raw["methods"].items() if m.get("summary")}
    res = dict(out=str(out), files=files, scenes=raw["scenes"], methods=summ, default_model=dk,
               run_s=raw["run_s"], cancelled=False)
    if dk and raw["methods"][dk].get("equal_quality"):
        e = raw["methods"][dk]["equal_quality"]["whole"]
        res["default_speedup"] = None if not math.isfinite(e["speedup"]) else dict(
            speedup=e["speedup"], bound=e["bound"], winner=e["winner"])
    return res
