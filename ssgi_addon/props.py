"""Scene settings of SSGI (``scene.ssgi``), shown by the panels and read by the operators."""
from __future__ import annotations

import bpy

from ..model import variants as _variants


class SSGI_SceneSettings(bpy.types.PropertyGroup):
    dataset_dir: bpy.props.StringProperty(name="Dataset", subtype="DIR_PATH", default="//ssgi_dataset/",
                                          description="Folder of the baked dataset (EXR samples + manifest.json)")
    model_path: bpy.props.StringProperty(name="Model", subtype="FILE_PATH", default="",
                                         description="Model checkpoint (.pt); empty uses the shipped default model")
    # Train panel (ssgi_addon/training.py)
    train_out: bpy.props.StringProperty(name="Save model as", subtype="FILE_PATH", default="",
                                        description="Checkpoint the training writes (best so far); empty: model.pt in the dataset folder")
    train_variant: bpy.props.EnumProperty(name="Network", default=_variants.DEFAULT,
                                          items=[(v, v, f"network variant {v}") for v in _variants.TRAINABLE])
    train_minutes: bpy.props.FloatProperty(name="Minutes", default=10.0, min=0.05, soft_max=240.0,
                                           description="Training time budget")
    train_resume: bpy.props.BoolProperty(name="Resume", default=False,
                                         description="Continue the last training of this model (its .last.pt)")


CLASSES = (SSGI_SceneSettings,)


def register_extra():
    bpy.types.Scene.ssgi = bpy.props.PointerProperty(type=SSGI_SceneSettings)


def unregister_extra():
    if hasattr(bpy.types.Scene, "ssgi"):
        del bpy.types.Scene.ssgi
