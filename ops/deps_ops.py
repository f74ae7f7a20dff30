"""Operators: install Python dependencies, cancel a background job."""
from __future__ import annotations

import bpy

from ..model.errors import UserError
from ..ssgi_addon.runtime import deps, jobs
from ..ssgi_addon.preferences import prefs


def start_install(target=None, requirement: str = deps.TORCH_REQUIREMENT, extra_args: str = "") -> jobs.Job:
    """Start the pip install of ``requirement`` (torch) into the extension's folder as a background job.
    The worker runs pip and reports its output lines; on success the folder goes first on sys.path and the
    torch status is checked again."""
    target = target or deps.deps_dir(create=True)
    if target is None:
        raise UserError("not running as an installed extension: no user folder to install into")
    cmd = deps.pip_command(target, requirement, extra_args=extra_args)

    def work(job: jobs.Job):
        job.report(message="running: " + " ".join(cmd[2:]))
        code, tail = deps.run_pip(cmd, on_line=lambda l: job.report(message=l), should_cancel=lambda: job.cancelled)
        job.check_cancel()
        if code != 0:
            last = [l for l in tail.splitlines() if l.strip()]
            raise UserError(f"pip exited with status {code}: {last[-1] if last else '(no output)'}")
        return {"target": str(target)}

    def done(job: jobs.Job):
        if job.result is not None:
            deps.add_to_path(target)
            ok, info = deps.torch_status(refresh=True)
            job.result["torch"] = info if ok else None
            job.state["message"] = f"installed into {target}; torch {info}" if ok else f"installed, but {info}"

    return jobs.Job("deps", work, on_done=done).start()


class SSGI_OT_install_deps(bpy.types.Operator):
    """Install PyTorch into this extension's own folder with pip (needs online access)"""
    bl_idname = "ssgi.install_deps"
    bl_label = "Install Python dependencies"

    def execute(self, context):
        if not bpy.app.online_access:
            self.report({"ERROR"}, "Online access is disabled (Preferences > System > Network): cannot install torch")
            return {"CANCELLED"}
        p = prefs(context)
        requirement = p.pip_requirement if p else deps.TORCH_REQUIREMENT
        try:
            start_install(requirement=requirement, extra_args=p.pip_extra_args if p else "")
        except (UserError, RuntimeError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        jobs.ensure_timer()
        self.report({"INFO"}, f"Installing {requirement} in the background")
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
