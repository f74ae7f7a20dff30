"""The Train panel (child of the SSGI panel in Render properties): settings, the Train button, and while a
training runs its epoch, loss, validation PSNR, ETA and a Cancel button. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import ui_jobs
from . import JobPanel


class SSGI_PT_train(JobPanel, bpy.types.Panel):
    bl_label = "Train"
    bl_idname = "SSGI_PT_train"
    job_name = ui_jobs.TRAIN
    start_op = "ssgi.train"

    @staticmethod
    def job_lines(state) -> list[str]:
        best = state.get("best_psnr")
        return [] if best is None else [f"Best validation PSNR {best:.2f} dB"]

    def draw_settings(self, col, s):
        col.prop(s, "dataset_dir")
        col.prop(s, "train_out")
        row = col.row()
        row.prop(s, "train_variant")
        row.prop(s, "train_minutes")
        col.prop(s, "train_resume")

    def draw_outcome(self, layout, job):
        st = job.state["status"]
        if st in ("done", "cancelled"):
            best = (job.result or {}).get("best", {}).get("val_psnr", job.state.get("best_psnr"))
            txt = f"{st.capitalize()} after epoch {job.state.get('epoch', 0)}"
            if best is not None:
                txt += f", best val PSNR {best:.2f} dB"
            layout.label(text=txt, icon="CHECKMARK" if st == "done" else "INFO")


CLASSES = (SSGI_PT_train,)
