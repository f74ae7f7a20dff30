"""The Report panel (child of the SSGI panel in Render properties): settings, the Report button, progress
with Cancel while it runs, and where the report went with its verdict on the default model. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import ui_jobs
from . import JobPanel


class SSGI_PT_report(JobPanel, bpy.types.Panel):
    bl_label = "Speed against Error Report"
    bl_idname = "SSGI_PT_report"
    job_name = ui_jobs.REPORT
    start_op = "ssgi.report"
    start_icon = "SORTTIME"
    error_limit = 140

    def draw_settings(self, col, s):
        col.prop(s, "report_models")
        col.prop(s, "report_out")
        col.prop(s, "report_max_scenes")

    def draw_result(self, layout, result):
        layout.label(text=f"Written: {result['files'].get('md', '')}", icon="CHECKMARK")
        if result.get("verdict"):
            layout.label(text=f"{result.get('default_model', '')}: {result['verdict']}"[:160])


CLASSES = (SSGI_PT_report,)
