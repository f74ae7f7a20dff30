"""The Fit to Scene panel (child of the SSGI panel in Render properties): settings, the button, and while a
fit runs its phase, progress, time left and Cancel; afterwards the verdict. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.pipeline import fit as sfit
from ..ssgi_addon.runtime import jobs
from . import SSGISubPanel, draw_error, draw_job, job_running


class SSGI_PT_fit(SSGISubPanel, bpy.types.Panel):
    bl_label = "Fit to Scene"
    bl_idname = "SSGI_PT_fit"

    def draw(self, context):
        layout = self.layout
        s = getattr(context.scene, "ssgi", None)
        if s is None:
            return
        job = jobs.get(sfit.JOB)
        running = job_running(job)
        col = layout.column()
        col.enabled = not running
        col.prop(s, "fit_out")
        row = col.row()
        row.prop(s, "fit_views")
        row.prop(s, "fit_minutes")
        col.prop(s, "fit_target_psnr")
        if draw_job(layout, job, sfit.status_text, "ssgi.cancel_job", job_name=sfit.JOB, cancel_text="Cancel", limit=120):
            return
        layout.operator("ssgi.fit_scene", icon="PLAY")
        if job is not None and not draw_error(layout, job):
            st = job.state.get("status")
            if st == "cancelled":
                layout.label(text="Cancelled; no model written", icon="INFO")
            elif st == "done" and job.result:
                layout.label(text=f"Inputs: {', '.join(job.result.get('inputs') or [])}", icon="CHECKMARK")
                for part in str(job.result.get("verdict", "")).split(": ", 1):
                    layout.label(text=part[:120])


CLASSES = (SSGI_PT_fit,)
