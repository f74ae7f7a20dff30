"""Operators: install Python dependencies, cancel a background job."""
from __future__ import annotations

import bpy

from ..ssgi_addon import deps, jobs


def start_install(target=None) -> jobs.Job:
    """Start the pip install of torch into the extension's folder as a background job."""
    target = target or deps.deps_dir(create=True)
    if target is None:
        raise RuntimeError("not running as an installed extension: no user folder to install into")
    cmd = deps.pip_command(target)

    def work(job: jobs.Job):
        job.report(message="running: " + " ".join(cmd[2:]))
        code, tail = deps.run_pip(cmd, on_line=lambda l: job.report(message=l), should_cancel=lambda: job.cancelled)
        job.check_cancel()
        if code != 0:
            raise RuntimeError(f"pip exited with status {code}: {tail.splitlines()[-1] if tail else ''}")
        return {"target": str(target)}

    def done(job: jobs.Job):
        if job.result is not None:
            deps.add_to_path(target)
            deps.torch_status(refresh=True)

    return jobs.Job("deps", work, on_done=done).start()


class SSGI_OT_install_deps(bpy.types.Operator):
    """Install PyTorch into this extension's own folder with pip (needs online access)"""
    bl_idname = "ssgi.install_deps"
    bl_label = "Install Python dependencies"

    def execute(self, context):
        if not bpy.app.online_access:
            self.report({"ERROR"}, "Online access is disabled (Preferences > System > Network): cannot install torch")
            return {"CANCELLED"}
        try:
            start_install()
        except RuntimeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        jobs.ensure_timer()
        self.report({"INFO"}, f"Installing {deps.TORCH_REQUIREMENT} in the background")
        return {"FINISHED"}


class SSGI_OT_cancel_job(bpy.types.Operator):
    """Cancel a running SSGI background job; completed work is kept"""
    bl_idname = "ssgi.cancel_job"
    bl_label = "Cancel"

    job: bpy.props.StringProperty()

    def execute(self, context):
        j = jobs.get(self.job)
        if j is None or j.done:
            self.report({"WARNING"}, f"no running {self.job} job")
            return {"CANCELLED"}
        j.cancel()
        return {"FINISHED"}


CLASSES = (SSGI_OT_install_deps, SSGI_OT_cancel_job)
