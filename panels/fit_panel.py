"""The Fit to Scene panel (child of the SSGI panel in Render properties): settings, the button, and while a
fit runs its phase, progress, time left and Cancel; afterwards the verdict. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import ui_jobs
from . import JobPanel


class SSGI_PT_fit(JobPanel, bpy.types.Panel):
    bl_label = "Fit to Scene"
    bl_idname = "SSGI_PT_fit"
    job_name = ui_jobs.FIT
    start_op = "ssgi.fit_scene"
    text_limit = 120
    cancelled_text = "Cancelled; no model written"

    def draw_settings(self, col, s):
        col.prop(s, "fit_out")
        row = col.row()
        row.prop(s, "fit_views")
        row.prop(s, "fit_minutes")
        col.prop(s, "fit_target_psnr")
        col.prop(s, "fit_one_render")
        col.prop(s, "fit_shot")
        if s.fit_shot:
            row = col.row()
            row.prop(s, "fit_frame_start")
            row.prop(s, "fit_frame_end")
            col.prop(s, "fit_lightmap")
            col.prop(s, "fit_reflmap")

    def draw_result(self, layout, result):
        layout.label(text=f"Inputs: {', '.join(result.get('inputs') or [])}", icon="CHECKMARK")
        for part in str(result.get("verdict", "")).split(": ", 1):
            layout.label(text=part[:120])


CLASSES = (SSGI_PT_fit,)
