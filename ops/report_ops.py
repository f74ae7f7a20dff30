"""Operator: Report. Thin: checks the settings, then runs ``cli.py report`` in a background process
(ssgi_addon/report_cli.py ``command`` / ``start_job``); the Report panel draws its progress. Cancel is the
shared ``ssgi.cancel_job`` (job "report")."""
from __future__ import annotations

from pathlib import Path

import bpy

from ..model.errors import UserError
from ..ssgi_addon.runtime import jobs
from ..ssgi_addon.blender import node
from ..ssgi_addon.paths import required_path, scene_path
from ..ssgi_addon.commands import report as report_cli


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
    from ..model.learn.data import read_manifest

    s = scene.ssgi
    data = Path(required_path(s.dataset_dir, "dataset folder"))
    read_manifest(data)
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


class SSGI_OT_report(bpy.types.Operator):
    """Render the dataset's validation scenes with every method (EEVEE, the models, Cycles at each sample count)
    and write the speed-against-error report (report.md, pareto.png, examples.png) in the background"""
    bl_idname = "ssgi.report"
    bl_label = "Report"

    options: bpy.props.StringProperty(name="Options", default="",
                                      description="More `cli.py report` options, e.g. --spp 1,2,4 --temporal-frames 0")

    @classmethod
    def poll(cls, context):
        job = jobs.get(report_cli.JOB)
        return context.scene is not None and (job is None or job.done)

    def execute(self, context):
        try:
            data, models, out = check(context.scene)
            cmd = report_cli.command(data, models, out, context.scene.ssgi.report_max_scenes, self.options)
            report_cli.start_job(cmd, out)
        except (UserError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        jobs.ensure_timer()
        self.report({"INFO"}, f"Report on {len(models)} model(s) -> {out}")
        return {"FINISHED"}


CLASSES = (SSGI_OT_report,)
