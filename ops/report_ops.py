"""Operator: Report. Thin: checks the settings, then runs ``cli.py report`` in a background process
(runtime/ui_jobs.py ``report``); the Report panel draws its progress. Cancel is ``ssgi.cancel_job`` (job
"report")."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..model.errors import UserError
from ..ssgi_addon.blender import node
from ..ssgi_addon.paths import required_path, scene_path
from ..ssgi_addon.runtime import ui_jobs
from . import StartsJob


def report_models(scene) -> list[Path]:
    """The scene's model (or the shipped default when it exists), then the extra models of the Report panel."""
    s = scene.ssgi
    out = []
    # scene.ssgi.model_path first, before an SSGI node's model (node.resolve_model puts the node's first)
    main = Path(scene_path(s.model_path, "Model")) if s.model_path else node.resolve_model(scene)
    if main.is_file() or s.model_path:
        out.append(main)
    for part in s.report_models.replace(",", ";").split(";"):
        if part.strip():
            p = Path(scene_path(part.strip(), "More models"))
            if p not in out:
                out.append(p)
    return out


def check(scene) -> tuple[Path, list[Path], Path]:
    """(dataset, models, out) of the scene's settings, or a UserError naming what is wrong."""
    from ..model.dataset.folder import open_folder

    s = scene.ssgi
    data = Path(required_path(s.dataset_dir, "dataset folder"))
    open_folder(data, scenes=True)
    models = report_models(scene)
    if not models:
        raise UserError("no model to report on: set the scene's model or add models to the Report panel")
    for m in models:
        if not m.is_file():
            raise UserError(f"{m}: no such model file")
    out = Path(scene_path(s.report_out, "Report folder") or data.parent / "ssgi_report")
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: is a file, not a folder")
    return data, models, out


class SSGI_OT_report(StartsJob, bpy.types.Operator):
    """Render the dataset's validation scenes with every method (EEVEE, the models, Cycles at each sample count)
    and write the speed-against-error report (report.md, pareto.png, examples.png) in the background"""
    bl_idname = "ssgi.report"
    bl_label = "Report"
    job_name = ui_jobs.REPORT

    options: bpy.props.StringProperty(name="Options", default="",
                                      description="More `cli.py report` options, e.g. --spp 1,2,4 --temporal-frames 0")

    def start_job(self, context):
        data, models, out = check(context.scene)
        ui_jobs.report(data, models, out, context.scene.ssgi.report_max_scenes, self.options).start()
        return f"Report on {len(models)} model(s) -> {out}"


CLASSES = (SSGI_OT_report,)
