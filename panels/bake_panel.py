"""The Dataset panel (child of the SSGI panel in Render properties): Randomize Room with its seed, and Bake
Dataset with its settings; while a bake runs, its progress, ETA and a Cancel button. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon.pipeline import bake
from . import SSGISubPanel, draw_error, draw_job, job_running


class SSGI_PT_bake(SSGISubPanel, bpy.types.Panel):
    bl_label = "Dataset"
    bl_idname = "SSGI_PT_bake"

    def draw(self, context):
        layout = self.layout
        s = getattr(context.scene, "ssgi", None)
        if s is None:
            return
        st = bake.STATE
        running = job_running(st)

        row = layout.row(align=True)
        row.enabled = not running
        row.prop(s, "room_seed")
        row.operator("ssgi.randomize_room", icon="FILE_REFRESH").seed = s.room_seed

        col = layout.column()
        col.enabled = not running
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

        if draw_job(layout, st, bake.status_text, "ssgi.bake_cancel", lines=lambda st: [st.get("message", "")[:120]]):
            return
        layout.operator("ssgi.bake_dataset", icon="RENDER_STILL")
        status = st.get("status")
        if not draw_error(layout, st) and status in ("done", "cancelled"):
            layout.label(text=f"{status.capitalize()}: {st.get('message', '')}"[:120],
                         icon="CHECKMARK" if status == "done" else "INFO")


CLASSES = (SSGI_PT_bake,)
