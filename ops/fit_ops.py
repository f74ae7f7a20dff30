"""Operator: Fit to Scene. Thin: checks the settings, saves a copy of the open file (unsaved changes
included) and starts ``cli.py fit`` on it in a background process (runtime/ui_jobs.py ``fit``). The Fit panel
draws its progress; Cancel is ``ssgi.cancel_job`` (job "fit"), which ends the process group."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..model.errors import UserError
from ..ssgi_addon.blender.views import check_shot
from ..ssgi_addon.paths import scene_path
from ..ssgi_addon.runtime import ui_jobs
from . import StartsJob


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


def fit_frames(scene) -> tuple[int, int] | None:
    """The shot the panel asks for: (start, end), 0 meaning the scene's own; None when "Fit the Shot" is off.
    The range is judged as ``cli.py fit --frames`` judges it (a one-line error, nothing started)."""
    s = scene.ssgi
    if not s.fit_shot:
        return None
    a = int(s.fit_frame_start) or scene.frame_start
    b = int(s.fit_frame_end) or scene.frame_end
    check_shot(a, b, scene)
    return a, b


class SSGI_OT_fit_scene(StartsJob, bpy.types.Operator):
    """Fit a small model to this scene in the background: bake views of its cameras (plus jittered ones), try
    network sizes smallest first, drop the input passes the scene does not need, and report. Blender stays usable"""
    bl_idname = "ssgi.fit_scene"
    bl_label = "Fit to Scene"
    job_name = ui_jobs.FIT
    needs_torch = True

    def start_job(self, context):
        scene = context.scene
        if not any(o.type == "CAMERA" for o in scene.objects):
            raise UserError(f"scene {scene.name!r} has no camera: add the camera(s) you render with")
        out = fit_out(scene)
        frames = fit_frames(scene)
        work = out.with_name(out.stem + ".fit")
        work.mkdir(exist_ok=True)
        copy = work / "source.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(copy), copy=True)
        s = scene.ssgi
        ui_jobs.fit(scene, str(copy), str(out), views=int(s.fit_views), minutes=float(s.fit_minutes),
                    target_psnr=float(s.fit_target_psnr) or None,
                    extra_args=(("--frames", f"{frames[0]}-{frames[1]}") if frames else ())
                    + (("--one-render",) if s.fit_one_render else ())
                    + (("--no-lightmap",) if frames and not s.fit_lightmap else ())
                    + (("--no-reflmap",) if frames and not s.fit_reflmap else ())).start()
        shot = f" (shot {frames[0]}-{frames[1]})" if frames else ""
        return f"Fitting to scene {scene.name!r}{shot} for {s.fit_minutes:g} min -> {out}"


CLASSES = (SSGI_OT_fit_scene,)
