"""The Fit to Scene panel (child of the SSGI panel in Render properties): settings, the button, and while a
fit runs its phase, progress, time left and Cancel; afterwards the verdict. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon import fit as sfit
from ..ssgi_addon import jobs


class SSGI_PT_fit(bpy.types.Panel):
    bl_label = "Fit to Scene"
    bl_idname = "SSGI_PT_fit"
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
        job = jobs.get(sfit.JOB)
        running = job is not None and not job.done
        col = layout.column()
        col.enabled = not running
        col.prop(s, "fit_out")
        row = col.row()
        row.prop(s, "fit_views")
        row.prop(s, "fit_minutes")
        col.prop(s, "fit_target_psnr")
        if running:
            layout.progress(factor=float(job.state.get("progress", 0.0)), type="BAR",
                            text=sfit.status_text(job.state)[:120])
            layout.operator("ssgi.cancel_job", text="Cancel", icon="CANCEL").job = sfit.JOB
            return
        layout.operator("ssgi.fit_scene", icon="PLAY")
        if job is not None:
            st = job.state.get("status")
            if st == "error":
                layout.label(text=(job.state.get("message") or "error")[:120], icon="ERROR")
            elif st == "cancelled":
                layout.label(text="Cancelled; no model written", icon="INFO")
            elif st == "done" and job.result:
                layout.label(text=f"Inputs: {', '.join(job.result.get('inputs') or [])}", icon="CHECKMARK")
                for part in str(job.result.get("verdict", "")).split(": ", 1):
                    layout.label(text=part[:120])


CLASSES = (SSGI_PT_fit,)
