"""The background jobs the UI starts, one per stage, each on the driver its work needs (runtime/jobs.py):

    bake(scene)     StepJob   "bake"    renders (main thread), one sample per step, rooms in a scratch scene
    render(...)     StepJob   "render"  renders (main thread), one frame per step
    train(scene)    ThreadJob "train"   model.learn.train.Trainer in a worker thread (torch, no bpy)
    fit(...)        ChildJob  "fit"     ``cli.py fit --progress --json`` on a saved copy of the open file
    report(...)     ChildJob  "report"  ``cli.py report --progress``; the result is read from OUT/report.json

(pip, the fourth child, is ``deps.start_install``.) The operators (ops/) check the UI's input, call one of
these and start the job; the panels draw ``job.state``. A job that changes the file when it ends (the scene's
model after a fit or a training) does so in ``on_done``, on the main thread.
"""
from __future__ import annotations

import json
import shlex
import time
from pathlib import Path

import bpy

from ...model.errors import UserError
from ..paths import required_path
from . import jobs, launcher

BAKE, RENDER, TRAIN, FIT, REPORT = "bake", "render", "train", "fit", "report"


def _set_model(scene_name: str, path) -> None:
    """Point the scene's model at ``path`` when it was written (main thread, a job's on_done)."""
    sc = bpy.data.scenes.get(scene_name)
    if sc is not None and path and Path(path).is_file():
        sc.ssgi.model_path = str(path)


# ------------------------------------------------------------------------------------------------ bake

def bake(scene) -> jobs.StepJob:
    """The Bake Dataset job of ``scene``'s settings (not started)."""
    s = scene.ssgi
    out = required_path(s.dataset_dir, "dataset folder")
    # with Denoise ticked the panel greys the target out: the reference takes exactly Reference Samples
    steps = _bake_steps(out, s.bake_count, s.bake_seed, (s.bake_width, s.bake_height), s.bake_ref_samples,
                        s.bake_denoise, 0.0 if s.bake_denoise else s.bake_ref_target_db)
    return jobs.StepJob(BAKE, steps, title="SSGI bake", status_bar=True)


def _bake_steps(out, count, seed, size, ref_samples, denoise, ref_target_db):
    """``pipeline.bake.iter_bake`` one sample per step. Rooms are built in a scratch scene that is removed at
    the end, so the user's scenes are never touched; a cancel stops before the next sample, and every sample
    written so far is complete and listed, so the same settings resume later. Returns the summary."""
    from ..blender import room
    from ..pipeline import bake as pbake

    scratch = bpy.data.scenes.new("SSGI Bake (temporary)")
    t0 = time.perf_counter()
    done, status = 0, "done"
    try:
        gen = pbake.iter_bake(out, count=count, seed=seed, size=size, ref_samples=ref_samples, denoise=denoise,
                              eevee_samples=pbake.BakeConfig.eevee_samples, scene=scratch,
                              ref_target_db=ref_target_db)
        try:
            start = next(gen)  # checks the settings and the folder: errors come now
            todo = start["todo"]
            try:  # a cancel may come before the first sample too: the summary says 0 baked
                yield dict(progress=0.0, done=0, todo=todo, total=start["total"], skipped=start["skipped"],
                           message=f"0/{todo} samples", detail=f"baking into {out}")
                for ev in gen:
                    if ev["event"] == "done":
                        break
                    done = ev["done"]
                    yield dict(done=done, progress=done / max(1, todo), eta_s=ev["eta_s"],
                               message=f"{done}/{todo} samples",
                               detail=f"sample {ev['sample']} (EEVEE {ev['eevee_s']:.1f} s, Cycles "
                                      f"{ev['cycles_s']:.1f} s, {ev['ref_samples']} spp)")
            except jobs.Cancelled:
                status = "cancelled"
        finally:
            gen.close()
    finally:
        if scratch.name in bpy.data.scenes:
            room.clear_room(scratch)  # its world too
            bpy.data.scenes.remove(scratch)
    return {"out": out, "baked": done, "skipped": start["skipped"], "total": start["total"], "status": status,
            "seconds": round(time.perf_counter() - t0, 2)}


# ------------------------------------------------------------------------------------------------ render

def render(scene, frames, model=None, out=None, write=True, samples=None) -> jobs.StepJob:
    """The Render SSGI job (not started); the session checks everything now and raises UserError."""
    from ..pipeline.render import RenderSession
    session = RenderSession(scene, frames, model=model, out=out, write=write, samples=samples)
    return jobs.StepJob(RENDER, _render_steps(session), title="SSGI render")


def _render_steps(session):
    """``RenderSession.iter_frames`` one frame per step; a cancel stops before the next frame (the frames
    written are kept). Returns the session's summary."""
    n = len(session.frames)
    stop = False
    try:
        yield dict(done=0, todo=n, progress=0.0, message=f"Rendering 0/{n}")
    except jobs.Cancelled:
        stop = True  # cancelled before the first frame: iter_frames renders none and the summary says so
    for info in session.iter_frames(lambda: stop):
        k = len(session.results)
        try:
            yield dict(done=k, progress=k / max(1, n), message=f"Rendering {k}/{n}: frame {info['frame']} done")
        except jobs.Cancelled:
            stop = True  # iter_frames sees it before the next frame and says so
    return session.summary()


# ------------------------------------------------------------------------------------------------ train

def train(scene, threads: int | None = None) -> jobs.ThreadJob:
    """Training with the scene's settings (not started). torch's thread count is the add-on preference (1 by
    default, see preferences.torch_threads); the worker only reports plain dicts; Cancel is checked before
    every batch and the last checkpoint stays; when it ends the scene's model points at the new one."""
    import torch

    from ...model.learn.train import Trainer
    from ..pipeline import training
    from ..preferences import torch_threads

    cfg = training.config_from_scene(scene)
    torch.set_num_threads(int(threads or torch_threads()))
    scene_name = scene.name

    def work(job: jobs.ThreadJob):
        def cb(d):
            msg = f"Epoch {d['epoch']}"
            if d.get("loss") is not None and d["loss"] == d["loss"]:
                msg += f" · loss {d['loss']:.4f}"
            if d.get("val_psnr") is not None:
                msg += f" · val {d['val_psnr']:.2f} dB"
            job.report(progress=d["progress"], epoch=d["epoch"], loss=d["loss"], val_psnr=d.get("val_psnr"),
                       best_psnr=d.get("best_psnr"), eta_s=d.get("eta_s"), step=d["step"], message=msg)

        res = Trainer(cfg, log=lambda m: job.report(log=m)).run(callback=cb, should_stop=lambda: job.cancelled)
        if res["status"] == "cancelled":
            job.check_cancel()
        return res

    def done(job):
        if job.result is not None:
            _set_model(scene_name, cfg.out)

    return jobs.ThreadJob(TRAIN, work, on_done=done, title="SSGI training", status_bar=True)


# ------------------------------------------------------------------------------------------------ fit

def fit(scene, blend_copy: str, out: str, views: int, minutes: float, target_psnr: float | None,
        threads: int | None = None, extra_args=()) -> jobs.ChildJob:
    """``cli.py fit`` on ``blend_copy`` (a saved copy of the open file) as a child process (not started).
    Cancel ends it and the baker it starts (one process group); nothing is written: the model appears only
    when the fit completes, and then becomes the scene's model."""
    args = ["fit", "--blend", str(blend_copy), "--scene", scene.name, "--out", str(out), "--views", str(views),
            "--minutes", f"{minutes:g}", "--progress", "--json", *extra_args]
    if target_psnr:
        args += ["--target-psnr", f"{target_psnr:g}"]
    if threads:
        args += ["--threads", str(threads)]
    scene_name = scene.name
    return jobs.ChildJob(FIT, launcher.cli_command(*args), env=launcher.cli_env(), what="cli.py fit",
                         result=lambda o: o.json() or {"model": str(out)},
                         on_done=lambda job: _set_model(scene_name, (job.result or {}).get("model")),
                         title="SSGI fit")


# ------------------------------------------------------------------------------------------------ report

def report(data, models, out, max_scenes: int, options: str = "") -> jobs.ChildJob:
    """``cli.py report`` as a child process (not started; the user's file is never touched: the report opens
    and builds its own scenes). ``options``: more command-line options, shell-style. The result is the
    summary read back from OUT/report.json (files, scenes, the default model's verdict)."""
    try:
        extra = shlex.split(options or "")
    except ValueError as e:
        raise UserError(f"report options {options!r}: {e}") from None
    cmd = launcher.cli_command("report", "--data", str(data), "--models", *map(str, models), "--out", str(out),
                               "--max-scenes", str(int(max_scenes)), "--progress", *extra)
    out = Path(out)

    def result(_outcome) -> dict:
        raw = json.loads((out / "report.json").read_text())
        res = dict(files=raw.get("files", {}), scenes=raw.get("scenes", []), run_s=raw.get("run_s"))
        dk = raw.get("default_model_key")
        if dk:
            res["verdict"] = (raw.get("verdicts", {}).get(dk) or [""])[0]
            res["default_model"] = raw["methods"][dk]["label"]
        return res

    job = jobs.ChildJob(REPORT, cmd, env=launcher.cli_env(), what="cli.py report", result=result,
                        message_lines="report: ", title="SSGI report")
    job.state["message"] = "starting: " + " ".join(cmd[-8:])
    return job
