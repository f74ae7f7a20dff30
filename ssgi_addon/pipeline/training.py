"""Training inside Blender: model.train.Trainer in a worker thread (jobs.Job), never touching bpy there.

``start(scene)`` reads the scene's settings on the main thread, sets torch's thread count (the add-on
preference; 1 by default, see preferences.torch_threads), and starts the job. The worker's callback only
``job.report``s plain dicts; ``jobs.pump`` (the UI timer, or tests) copies them into ``job.state``, which the
Train panel and the status bar draw. Cancel sets the job's flag, which the trainer checks before every
batch; the last checkpoint stays. When the job ends, the main thread points ``scene.ssgi.model_path`` at the
new model (if one was written).
"""
from __future__ import annotations

from pathlib import Path

import bpy

from ..runtime import jobs
from ..paths import required_path, scene_path
from ..preferences import torch_threads

JOB = "train"


def config_from_scene(scene):
    """A TrainConfig from ``scene.ssgi`` (main thread only)."""
    from ...model.learn.train import TrainConfig

    s = scene.ssgi
    data = required_path(s.dataset_dir, "dataset folder")
    out = scene_path(s.train_out, "Save model as") or str(Path(data) / "model.pt")
    return TrainConfig(data=data, out=out, variant=s.train_variant, minutes=float(s.train_minutes),
                       resume=bool(s.train_resume), command=f"Blender Train operator: {bpy.data.filepath or 'unsaved file'}")


def start(scene, threads: int | None = None) -> jobs.Job:
    """Start training with the scene's settings; returns the running job."""
    import torch

    from ...model.learn.train import Trainer

    cfg = config_from_scene(scene)
    torch.set_num_threads(int(threads or torch_threads()))
    scene_name = scene.name

    def work(job: jobs.Job):
        def cb(d):
            msg = f"epoch {d['epoch']}"
            if d.get("val_psnr") is not None:
                msg += f", val {d['val_psnr']:.2f} dB"
            job.report(progress=d["progress"], epoch=d["epoch"], loss=d["loss"], val_psnr=d.get("val_psnr"),
                       best_psnr=d.get("best_psnr"), eta_s=d.get("eta_s"), step=d["step"], message=msg)

        res = Trainer(cfg, log=lambda m: job.report(log=m)).run(callback=cb, should_stop=lambda: job.cancelled)
        if res["status"] == "cancelled":
            job.check_cancel()
        return res

    def done(job: jobs.Job):
        out = Path(cfg.out)
        sc = bpy.data.scenes.get(scene_name)
        if sc is not None and out.is_file() and job.result is not None:
            sc.ssgi.model_path = str(out)

    return jobs.Job(JOB, work, on_done=done).start()


def status_text(state: dict) -> str:
    """One line for the panel and the status bar."""
    parts = [f"Epoch {state.get('epoch', 0)}"]
    if state.get("loss") is not None and state["loss"] == state["loss"]:
        parts.append(f"loss {state['loss']:.4f}")
    if state.get("val_psnr") is not None:
        parts.append(f"val {state['val_psnr']:.2f} dB")
    if state.get("eta_s") is not None:
        parts.append(f"ETA {state['eta_s'] / 60:.1f} min")
    return " · ".join(parts)


def draw_status(self, context):
    """Status-bar progress of a running training (appended to STATUSBAR_HT_header)."""
    job = jobs.get(JOB)
    if job is None or job.done:
        return
    self.layout.progress(factor=float(job.state.get("progress", 0.0)), type="BAR",
                         text="SSGI training: " + status_text(job.state))


def register_extra():
    bpy.types.STATUSBAR_HT_header.append(draw_status)


def unregister_extra():
    try:
        bpy.types.STATUSBAR_HT_header.remove(draw_status)
    except ValueError:
        pass
