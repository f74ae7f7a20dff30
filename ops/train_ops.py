"""Operators: Train (start the background training job) and Cancel Training. Thin: ssgi_addon.training does
the work; the model half (model/train.py) is the same code ``cli.py train`` runs."""
from __future__ import annotations

import bpy

from ..model.errors import UserError
from ..ssgi_addon.runtime import deps, jobs
from ..ssgi_addon.pipeline import training


class SSGI_OT_train(bpy.types.Operator):
    """Train a network on the dataset folder in the background; Blender stays usable while it trains"""
    bl_idname = "ssgi.train"
    bl_label = "Train"

    @classmethod
    def poll(cls, context):
        job = jobs.get(training.JOB)
        return context.scene is not None and (job is None or job.done)

    def execute(self, context):
        ok, info = deps.torch_status()
        if not ok:
            self.report({"ERROR"}, "PyTorch is not installed: install it in Preferences > Add-ons > SSGI")
            return {"CANCELLED"}
        try:
            cfg = training.config_from_scene(context.scene)
            cfg.check()
            from ..model.dataset.folder import open_folder
            open_folder(cfg.data, scenes=True)  # a missing or foreign dataset is reported now, not from the thread
            training.start(context.scene)
        except (UserError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        jobs.ensure_timer()
        self.report({"INFO"}, f"Training {cfg.variant} for {cfg.minutes:g} min -> {cfg.out}")
        return {"FINISHED"}


class SSGI_OT_train_cancel(bpy.types.Operator):
    """Stop the training after the current batch; the last checkpoint is kept"""
    bl_idname = "ssgi.train_cancel"
    bl_label = "Cancel Training"

    def execute(self, context):
        job = jobs.get(training.JOB)
        if job is None or job.done:
            self.report({"WARNING"}, "no training is running")
            return {"CANCELLED"}
        job.cancel()
        return {"FINISHED"}


CLASSES = (SSGI_OT_train, SSGI_OT_train_cancel)
