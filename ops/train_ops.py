"""Operator: Train (start the background training job, runtime/ui_jobs.py ``train``). Thin: the model half
(model/learn/train.py) is the same code ``cli.py train`` runs; Cancel is ``ssgi.cancel_job`` (job "train")."""
from __future__ import annotations

import bpy

from ..ssgi_addon.pipeline import training
from ..ssgi_addon.runtime import ui_jobs
from . import StartsJob


class SSGI_OT_train(StartsJob, bpy.types.Operator):
    """Train a network on the dataset folder in the background; Blender stays usable while it trains"""
    bl_idname = "ssgi.train"
    bl_label = "Train"
    job_name = ui_jobs.TRAIN
    needs_torch = True

    def start_job(self, context):
        cfg = training.config_from_scene(context.scene)
        cfg.check()
        from ..model.dataset.folder import open_folder
        open_folder(cfg.data, scenes=True)  # a missing or foreign dataset is reported now, not from the thread
        ui_jobs.train(context.scene).start()
        return f"Training {cfg.variant} for {cfg.minutes:g} min -> {cfg.out}"


CLASSES = (SSGI_OT_train,)
