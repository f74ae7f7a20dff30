"""Scene settings of SSGI (``scene.ssgi``), shown by the panels and read by the operators."""
from __future__ import annotations

import bpy


class SSGI_SceneSettings(bpy.types.PropertyGroup):
    dataset_dir: bpy.props.StringProperty(name="Dataset", subtype="DIR_PATH", default="//ssgi_dataset/",
                                          description="Folder of the baked dataset (EXR samples + manifest.json)")
    model_path: bpy.props.StringProperty(name="Model", subtype="FILE_PATH", default="",
                                         description="Model checkpoint (.pt); empty uses the shipped default model")


CLASSES = (SSGI_SceneSettings,)


def register_extra():
    bpy.types.Scene.ssgi = bpy.props.PointerProperty(type=SSGI_SceneSettings)


def unregister_extra():
    if hasattr(bpy.types.Scene, "ssgi"):
        del bpy.types.Scene.ssgi
