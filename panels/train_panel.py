"""The Train panel (child of the SSGI panel in Render properties): settings, the Train button, and while a
training runs its epoch, loss, validation PSNR, ETA and a Cancel button. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import jobs
from ..ssgi_addon.pipeline import training
from . import SSGISubPanel, draw_error, draw_job, job_running


class SSGI_PT_train(SSGISubPanel, bpy.types.Panel):
    bl_label = "Train"
    bl_idname = "SSGI_PT_train"

    def draw(self, context):
        layout = self.layout
        s = getattr(context.scene, "ssgi", None)
        if s is None:
            return
        job = jobs.get(training.JOB)
        running = job_running(job)
        col = layout.column()
        col.enabled = not running
        col.prop(s, "dataset_dir")
        col.prop(s, "train_out")
        row = col.row()
        row.prop(s, "train_variant")
        row.prop(s, "train_minutes")
        col.prop(s, "train_resume")
        if draw_job(layout, job, training.status_text, "ssgi.train_cancel", lines=_best_line):
            return
        layout.operator("ssgi.train", icon="PLAY")
        if job is not None and not draw_error(layout, job):
            st = job.state.get("status")
            if st in ("done", "cancelled"):
                best = (job.result or {}).get("best", {}).get("val_psnr", job.state.get("best_psnr"))
                txt = f"{st.capitalize()} after epoch {job.state.get('epoch', 0)}"
                if best is not None:
                    txt += f", best val PSNR {best:.2f} dB"
                layout.label(text=txt, icon="CHECKMARK" if st == "done" else "INFO")


def _best_line(state) -> list[str]:
    best = state.get("best_psnr")
    return [] if best is None else [f"Best validation PSNR {best:.2f} dB"]


CLASSES = (SSGI_PT_train,)
