"""The Report panel (child of the SSGI panel in Render properties): settings, the Report button, progress
with Cancel while it runs, and where the report went with its verdict on the default model. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import jobs
from ..ssgi_addon.commands import report as report_cli
from . import SSGISubPanel, draw_error, draw_job, job_running


class SSGI_PT_report(SSGISubPanel, bpy.types.Panel):
    bl_label = "Speed against Error Report"
    bl_idname = "SSGI_PT_report"

    def draw(self, context):
        layout = self.layout
        s = getattr(context.scene, "ssgi", None)
        if s is None:
            return
        job = jobs.get(report_cli.JOB)
        running = job_running(job)
        col = layout.column()
        col.enabled = not running
        col.prop(s, "report_models")
        col.prop(s, "report_out")
        col.prop(s, "report_max_scenes")
        if draw_job(layout, job, report_cli.status_text, "ssgi.cancel_job", job_name=report_cli.JOB):
            return
        layout.operator("ssgi.report", icon="SORTTIME")
        if job is None or draw_error(layout, job, limit=140):
            return
        st = job.state.get("status")
        if st == "cancelled":
            layout.label(text="Cancelled", icon="INFO")
        elif st == "done" and job.result:
            layout.label(text=f"Written: {job.result['files'].get('md', '')}", icon="CHECKMARK")
            if job.result.get("verdict"):
                layout.label(text=f"{job.result.get('default_model', '')}: {job.result['verdict']}"[:160])


CLASSES = (SSGI_PT_report,)
