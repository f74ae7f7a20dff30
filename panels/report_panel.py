"""The Report panel (child of the SSGI panel in Render properties): settings, the Report button, progress
with Cancel while it runs, and where the report went with its verdict on the default model. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon import jobs, report_cli


class SSGI_PT_report(bpy.types.Panel):
    bl_label = "Speed against Error Report"
    bl_idname = "SSGI_PT_report"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    bl_parent_id = "SSGI_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        s = getattr(context.scene, "ssgi", None)
        if s is None:
            return
        job = jobs.get(report_cli.JOB)
        running = job is not None and not job.done
        col = layout.column()
        col.enabled = not running
        col.prop(s, "report_models")
        col.prop(s, "report_out")
        col.prop(s, "report_max_scenes")
        if running:
            layout.progress(factor=float(job.state.get("progress", 0.0)), type="BAR",
                            text=report_cli.status_text(job.state))
            layout.operator("ssgi.cancel_job", icon="CANCEL").job = report_cli.JOB
            return
        layout.operator("ssgi.report", icon="SORTTIME")
        if job is None:
            return
        st = job.state.get("status")
        if st == "error":
            layout.label(text=(job.state.get("message") or "error")[:140], icon="ERROR")
        elif st == "cancelled":
            layout.label(text="Cancelled", icon="INFO")
        elif st == "done" and job.result:
            layout.label(text=f"Written: {job.result['files'].get('md', '')}", icon="CHECKMARK")
            if job.result.get("verdict"):
                layout.label(text=f"{job.result.get('default_model', '')}: {job.result['verdict']}"[:160])


CLASSES = (SSGI_PT_report,)
