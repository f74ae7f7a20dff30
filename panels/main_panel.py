"""The SSGI panel in Render properties; feature panels are its children."""
from __future__ import annotations

import bpy

from ..ssgi_addon.runtime import deps
from . import RenderPropertiesPanel


class SSGI_PT_main(RenderPropertiesPanel, bpy.types.Panel):
    bl_label = "SSGI"
    bl_idname = "SSGI_PT_main"

    def draw(self, context):
        layout = self.layout
        ok, info = deps.torch_status()
        if not ok:
            col = layout.column()
            col.label(text="PyTorch missing: training, fit and report are off.", icon="ERROR")
            col.label(text="The SSGI node runs ONNX models (bundled onnxruntime); Randomize and Bake work.")
            col.label(text="Install PyTorch from Preferences > Add-ons > SSGI.")
        settings = getattr(context.scene, "ssgi", None)
        if settings is not None:
            layout.prop(settings, "dataset_dir")
            row = layout.row(align=True)
            row.prop(settings, "model_choice")
            row.operator("ssgi.export_onnx", text="", icon="EXPORT")
            if settings.model_choice == "CUSTOM":
                layout.prop(settings, "model_path")


CLASSES = (SSGI_PT_main,)
