"""The Dataset panel (child of the SSGI panel in Render properties): Randomize Room with its seed, and Bake
Dataset with its settings; while a bake runs, its progress, ETA and a Cancel button. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import ui_jobs
from . import JobPanel


class SSGI_PT_bake(JobPanel, bpy.types.Panel):
    bl_label = "Dataset"
    bl_idname = "SSGI_PT_bake"
    job_name = ui_jobs.BAKE
    start_op = "ssgi.bake_dataset"
    start_icon = "RENDER_STILL"

    @staticmethod
    def job_lines(state) -> list[str]:
        return [state.get("detail", "")[:120]]

    def draw_settings(self, col, s):
        row = col.row(align=True)
        row.prop(s, "room_seed")
        row.prop(s, "room_mode", text="")
        op = row.operator("ssgi.randomize_room", icon="FILE_REFRESH")
        op.seed, op.mode = s.room_seed, s.room_mode
        col.prop(s, "dataset_dir")
        row = col.row(align=True)
        row.prop(s, "bake_count")
        row.prop(s, "bake_seed")
        row = col.row(align=True)
        row.prop(s, "bake_width")
        row.prop(s, "bake_height")
        col.prop(s, "bake_ref_samples")
        row = col.row()
        row.active = not s.bake_denoise  # with Denoise the reference takes exactly Reference Samples
        row.prop(s, "bake_ref_target_db")
        col.prop(s, "bake_denoise")

    def draw_outcome(self, layout, job):
        r, status = job.result, job.state["status"]
        if r and status in ("done", "cancelled"):
            layout.label(text=f"{status.capitalize()}: {r['baked']} baked, {r['skipped']} already there -> "
                              f"{r['out']}"[:120], icon="CHECKMARK" if status == "done" else "INFO")


CLASSES = (SSGI_PT_bake,)
