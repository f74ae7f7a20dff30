"""Operator: Fit to Scene. Thin: checks the settings, saves a copy of the open file (unsaved changes
included) and starts ``cli.py fit`` on it in a background process (ssgi_addon/fit.py ``start``). The Fit panel
draws its progress; Cancel is the shared ``ssgi.cancel_job`` (job "fit"), which ends the process."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..model.errors import UserError
from ..ssgi_addon.runtime import deps, jobs
from ..ssgi_addon.pipeline import fit as sfit
from ..ssgi_addon.paths import scene_path


def fit_out(scene) -> Path:
    """The model the fit writes: the panel's "Save model as", or <file>_ssgi_fit.pt beside the saved .blend."""
    s = scene.ssgi
    if s.fit_out:
        out = Path(scene_path(s.fit_out, "Save model as"))
    elif bpy.data.filepath:
        b = Path(bpy.data.filepath)
        out = b.with_name(f"{b.stem}_{scene.name}_ssgi_fit.pt")
    else:
        raise UserError("set 'Save model as' in the Fit panel, or save the .blend first")
    if out.suffix != ".pt":
        out = out.with_suffix(".pt")
    if not out.parent.is_dir():
        raise UserError(f"{out.parent}: folder does not exist (the fitted model goes there)")
    return out


class SSGI_OT_fit_scene(bpy.types.Operator):
    """Fit a small model to this scene in the background: bake views of its cameras (plus jittered ones), try
    network sizes smallest first, drop the input passes the scene does not need, and report. Blender stays usable"""
    bl_idname = "ssgi.fit_scene"
    bl_label = "Fit to Scene"

    @classmethod
    def poll(cls, context):
        job = jobs.get(sfit.JOB)
        return context.scene is not None and (job is None or job.done)

    def execute(self, context):
        scene = context.scene
        ok, _info = deps.torch_status()
        if not ok:
            self.report({"ERROR"}, "PyTorch is not installed: install it in Preferences > Add-ons > SSGI")
            return {"CANCELLED"}
        try:
            if not any(o.type == "CAMERA" for o in scene.objects):
                raise UserError(f"scene {scene.name!r} has no camera: add the camera(s) you render with")
            out = fit_out(scene)
            work = out.with_name(out.stem + ".fit")
            work.mkdir(exist_ok=True)
            copy = work / "source.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(copy), copy=True)
            s = scene.ssgi
            sfit.start(scene, str(copy), str(out), views=int(s.fit_views), minutes=float(s.fit_minutes),
                       target_psnr=float(s.fit_target_psnr) or None)
        except (UserError, RuntimeError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        jobs.ensure_timer()
        self.report({"INFO"}, f"Fitting to scene {scene.name!r} for {s.fit_minutes:g} min -> {out}")
        return {"FINISHED"}


CLASSES = (SSGI_OT_fit_scene,)
