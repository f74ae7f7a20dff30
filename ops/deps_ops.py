"""Operator: install Python dependencies (the pip job, runtime/deps.py ``start_install``)."""
from __future__ import annotations

import bpy

from ..model.errors import UserError
from ..ssgi_addon.preferences import prefs
from ..ssgi_addon.runtime import deps, jobs
from . import StartsJob


class SSGI_OT_install_deps(StartsJob, bpy.types.Operator):
    """Install PyTorch into this extension's own folder with pip (needs online access)"""
    bl_idname = "ssgi.install_deps"
    bl_label = "Install Python dependencies"
    job_name = "deps"

    @classmethod
    def poll(cls, context):
        return not jobs.running(cls.job_name)

    def start_job(self, context):
        if not bpy.app.online_access:
            raise UserError("Online access is disabled (Preferences > System > Network): cannot install torch")
        p = prefs(context)
        requirement = p.pip_requirement if p else deps.TORCH_REQUIREMENT
        deps.start_install(requirement=requirement, extra_args=p.pip_extra_args if p else "")
        return f"Installing {requirement} in the background"


CLASSES = (SSGI_OT_install_deps,)
