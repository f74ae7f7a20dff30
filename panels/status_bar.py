"""The status bar's SSGI progress: one bar per running job that asks for it (``Job.status_bar``: the bake
and the training). It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import jobs


def draw_status(self, context):
    """Appended to STATUSBAR_HT_header."""
    for job in jobs.running_jobs():
        if job.status_bar:
            self.layout.progress(factor=float(job.state.get("progress") or 0.0), type="BAR",
                                 text=f"{job.title}: {jobs.status_text(job.state)}")


def register_extra():
    bpy.types.STATUSBAR_HT_header.append(draw_status)


def unregister_extra():
    try:
        bpy.types.STATUSBAR_HT_header.remove(draw_status)
    except ValueError:
        pass
