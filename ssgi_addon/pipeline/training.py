"""Training inside Blender: the TrainConfig of a scene's settings. The job that trains with it in a worker
thread is runtime/ui_jobs.py ``train``."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..paths import required_path, scene_path


def config_from_scene(scene):
    """A TrainConfig from ``scene.ssgi`` (main thread only)."""
    from ...model.learn.config import TrainConfig

    s = scene.ssgi
    data = required_path(s.dataset_dir, "dataset folder")
    out = scene_path(s.train_out, "Save model as") or str(Path(data) / "model.pt")
    return TrainConfig(data=data, out=out, variant=s.train_variant, minutes=float(s.train_minutes),
                       resume=bool(s.train_resume), command=f"Blender Train operator: {bpy.data.filepath or 'unsaved file'}")
