"""The Dataset panel (child of the SSGI panel in Render properties): Randomize Room with its seed, and Bake
Dataset with its settings; while a bake runs, its progress, ETA and a Cancel button. It only draws."""
from __future__ import annotations

import bpy

from ..ssgi_addon import bake


class SSGI_PT_bake(bpy.types.Panel):
    bl_label = "Dataset"
    bl_idname = "SSGI_PT_bake"
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
        st = bake.STATE
        running = st.get("status") == "running"

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
        col.prop(s, "bake_denoise")

        if running:
            layout.progress(factor=float(st.get("progress", 0.0)), type="BAR", text=bake.status_text(st))
            layout.label(text=st.get("message", "")[:120])
            layout.operator("ssgi.bake_cancel", icon="CANCEL")
            return
        layout.operator("ssgi.bake_dataset", icon="RENDER_STILL")
        status = st.get("status")
        if status == "error":
            layout.label(text=st.get("message", "error")[:120], icon="ERROR")
        elif status in ("done", "cancelled"):
            layout.label(text=f"{status.capitalize()}: {st.get('message', '')}"[:120],
                         icon="CHECKMARK" if status == "done" else "INFO")


CLASSES = (SSGI_PT_bake,)
