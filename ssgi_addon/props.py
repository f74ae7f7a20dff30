"""Scene settings of SSGI (``scene.ssgi``), shown by the panels and read by the operators. Their defaults are
the stages' (TrainConfig, BakeConfig, FitSceneConfig, ReportConfig), so the UI and the command line start from the same
settings; paths.py turns the path settings into absolute paths."""
from __future__ import annotations

import bpy

from ..model import shipped as _shipped
from ..model.learn import variants as _variants
from ..model.learn.config import DEFAULT_MINUTES as _TRAIN_MINUTES, TrainConfig as _Train
from .blender.reference import DEFAULT_REF_TARGET_DB, DENOISED_REF_SAMPLES
from .pipeline.bake import BakeConfig as _Bake
from .pipeline.fit import FitSceneConfig as _Fit
from .pipeline.randomize import RandomizeConfig as _Randomize
from .pipeline.report import ReportConfig as _Report


ROOM_MODES = [("diffuse", "Diffuse", "A box of diffuse primitives lit by lamps (the seed's rooms)"),
              ("artist", "Artist", "Principled, metal, glass and textured materials, emissive lights, skies, "
                                   "open rooms and exteriors"),
              ("studio", "Studio", "A cyclorama in a dark stage lit by softboxes, metal and glass props"),
              ("interior", "Interior", "Bright white and beige plaster rooms, closed or with windows, artist "
                                       "materials and lights")]


_MENU = [k for k, _, _ in _shipped.menu_items()]


def _get_model_choice(settings) -> int:
    return _MENU.index(_shipped.menu_choice(settings.model_path, settings.model_custom))


def _set_model_choice(settings, i: int) -> None:
    settings.model_path, settings.model_custom = _shipped.setting_for(_MENU[i], settings.model_path)


class SSGI_SceneSettings(bpy.types.PropertyGroup):
    dataset_dir: bpy.props.StringProperty(name="Dataset", subtype="DIR_PATH", default="//ssgi_dataset/",
                                          description="Folder of the baked dataset (EXR samples + manifest.json)")
    model_path: bpy.props.StringProperty(name="Model file", subtype="FILE_PATH", default="",
                                         description="Your model: a checkpoint (.pt; its .onnx export beside it runs "
                                                     "without PyTorch) or an .onnx export; empty uses the default "
                                                     "model")
    model_custom: bpy.props.BoolProperty(name="Custom model", default=False, options={"HIDDEN"},
                                         description="The model menu shows Custom file (model_path holds the file)")
    model_choice: bpy.props.EnumProperty(
        name="Model", items=_shipped.menu_items(),
        get=_get_model_choice, set=_set_model_choice,
        description="The model that predicts the light: a shipped one, or a file of your own")
    # Train panel (ssgi_addon/pipeline/training.py, runtime/ui_jobs.py train)
    train_out: bpy.props.StringProperty(name="Save model as", subtype="FILE_PATH", default="",
                                        description="Checkpoint the training writes (best so far); empty: model.pt in the dataset folder")
    train_variant: bpy.props.EnumProperty(name="Network", default=_Train.variant,
                                          items=[(v, v, f"network variant {v}") for v in _variants.TRAINABLE])
    train_minutes: bpy.props.FloatProperty(name="Minutes", default=_TRAIN_MINUTES, min=0.05, soft_max=240.0,
                                           description="Training time budget")
    train_resume: bpy.props.BoolProperty(name="Resume", default=False,
                                         description="Continue the last training of this model (its .last.pt)")
    # Report panel (ssgi_addon/pipeline/report.py)
    report_models: bpy.props.StringProperty(name="More models", default="",
                                            description="More checkpoints to compare, separated by ';' (network sizes, the linear baseline)")
    report_out: bpy.props.StringProperty(name="Report folder", subtype="DIR_PATH", default="",
                                         description="Where report.md, pareto.png, examples.png go; empty: ssgi_report beside the dataset")
    report_max_scenes: bpy.props.IntProperty(name="Scenes", default=_Report.max_scenes, min=1, soft_max=50,
                                             description="Evaluate at most this many validation scenes")
    # Fit to Scene panel (ssgi_addon/pipeline/fit.py)
    fit_out: bpy.props.StringProperty(name="Save model as", subtype="FILE_PATH", default="",
                                      description="The fitted model (.pt); empty: <file>_<scene>_ssgi_fit.pt beside the .blend")
    fit_views: bpy.props.IntProperty(name="Views", default=_Fit.views, min=4, soft_max=200,
                                     description="About how many views of the scene to bake (some are held out)")
    fit_minutes: bpy.props.FloatProperty(name="Minutes", default=_Fit.minutes, min=0.1, soft_max=240.0,
                                         description="The whole time budget of the fit, bake included")
    fit_shot: bpy.props.BoolProperty(name="Fit the Shot", default=False,
                                     description="Fit frames Start..End as one shot: 5 whole frames spread over it are "
                                                 "withheld (nothing baked within a frame of them) and scored after the "
                                                 "fit as the node renders them, beside the shipped model and Cycles 1 spp + OIDN")
    fit_frame_start: bpy.props.IntProperty(name="Start", default=0, min=0,
                                           description="First frame of the shot; 0: the scene's frame start")
    fit_frame_end: bpy.props.IntProperty(name="End", default=0, min=0,
                                         description="Last frame of the shot; 0: the scene's frame end")
    fit_one_render: bpy.props.BoolProperty(name="One Render (no EEVEE GI)", default=False,
                                           description="Fit a model whose frames are one EEVEE render with ray tracing "
                                                       "and fast GI off: the fitted network gives the GI, a frame costs "
                                                       "about what EEVEE's own GI costs at the same samples (cli.py fit "
                                                       "--one-render)")
    fit_reflmap: bpy.props.BoolProperty(name="Shot Reflection Map", default=True,
                                        description="With Fit the Shot: when the scene has mirrors or metal, also fit a "
                                                    "world-space correction of EEVEE's reflections beside the model "
                                                    "(its views then hold EEVEE's rest; off: cli.py fit --no-reflmap)")
    fit_lightmap: bpy.props.BoolProperty(name="Shot Lightmap", default=True,
                                         description="With Fit the Shot: also fit a lightmap of the shot's diffuse light "
                                                     "in world space beside the model, blended where the fit's validation "
                                                     "views say it helps (off: cli.py fit --no-lightmap)")
    fit_target_psnr: bpy.props.FloatProperty(name="Target PSNR", default=0.0, min=0.0, soft_max=60.0,
                                             description="Held-out PSNR (dB) to reach; 0: the shipped model's + 2 dB")
    # Dataset panel (ops/bake_ops.py): Randomize Room and Bake Dataset (defaults as cli.py randomize / bake)
    room_seed: bpy.props.IntProperty(name="Room Seed", default=_Randomize.seed, min=0, description="Seed of the random room")
    room_mode: bpy.props.EnumProperty(name="Room Kind", default=_Randomize.mode, items=ROOM_MODES,
                                      description="What Randomize Room builds")
    bake_count: bpy.props.IntProperty(name="Rooms", default=_Bake.count, min=0, soft_max=2000,
                                      description="Number of random rooms to bake (room i uses seed + i)")
    bake_seed: bpy.props.IntProperty(name="First Seed", default=_Bake.seed, min=0, description="Seed of the first room")
    bake_width: bpy.props.IntProperty(name="Width", default=_Bake.size[0], min=1, max=16384, subtype="PIXEL")
    bake_height: bpy.props.IntProperty(name="Height", default=_Bake.size[1], min=1, max=16384, subtype="PIXEL")
    bake_ref_samples: bpy.props.IntProperty(name="Reference Samples", default=_Bake.ref_samples, min=1,
                                            soft_max=4096,
                                            description="Cycles samples per pixel of the reference: the most it "
                                                        "may take to reach Target Agreement, or exactly this many "
                                                        "with a target of 0 or with Denoise "
                                                        f"({DENOISED_REF_SAMPLES} with Denoise agree to >= 40 "
                                                        "dB, ~3 s a 240x135 room here)")
    bake_ref_target_db: bpy.props.FloatProperty(name="Target Agreement (dB)", default=DEFAULT_REF_TARGET_DB,
                                                min=0.0, soft_max=60.0,
                                                description="Render the raw reference as two halves of different "
                                                            "seeds, doubling them until two such references would "
                                                            "agree to this PSNR (0: a fixed Reference Samples)")
    bake_denoise: bpy.props.BoolProperty(name="Denoise Reference", default=_Bake.denoise,
                                         description="Denoise the Cycles reference with OpenImageDenoise (off by "
                                                     "default; recorded in the dataset's manifest)")


CLASSES = (SSGI_SceneSettings,)


def register_extra():
    bpy.types.Scene.ssgi = bpy.props.PointerProperty(type=SSGI_SceneSettings)


def unregister_extra():
    if hasattr(bpy.types.Scene, "ssgi"):
        del bpy.types.Scene.ssgi
