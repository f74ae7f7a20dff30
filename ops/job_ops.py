"""Operator: Cancel, the one for every background job (bake, render, train, fit, report, deps)."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import jobs


class SSGI_OT_cancel_job(bpy.types.Operator):
    """Cancel a running SSGI background job; completed work is kept"""
    bl_idname = "ssgi.cancel_job"
    bl_label = "Cancel"

    job: bpy.props.StringProperty(name="Job", description="Name of the job to cancel (bake, render, train, ...)")

    def execute(self, context):
        j = jobs.get(self.job)
        if j is None or j.done:
            self.report({"WARNING"}, f"no running {self.job} job")
            return {"CANCELLED"}
        j.cancel()
        return {"FINISHED"}


CLASSES = (SSGI_OT_cancel_job,)
