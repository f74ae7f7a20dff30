"""UI panels: draw state, never compute.

``draw_job`` is the one way a panel shows a running background job (progress bar, lines under it, Cancel);
``job_running`` and ``draw_error`` go with it. A job is a ``jobs.Job``, a plain state dict (the bake's
``bake.STATE``) or None (never started)."""
from __future__ import annotations


class RenderPropertiesPanel:
    """Mixin (before ``bpy.types.Panel``) for panels in Render properties, as Blender's own
    ``properties_render.RenderButtonsPanel``."""
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"


class SSGISubPanel(RenderPropertiesPanel):
    """Mixin for the closed-by-default child panels of the SSGI panel."""
    bl_parent_id = "SSGI_PT_main"
    bl_options = {"DEFAULT_CLOSED"}


def job_state(job) -> dict:
    """The state dict of ``job`` ({} for None)."""
    if job is None:
        return {}
    return job if isinstance(job, dict) else job.state


def job_running(job) -> bool:
    """True while ``job`` runs: a Job not done yet, or a state dict whose status is "running"."""
    if job is None:
        return False
    if isinstance(job, dict):
        return job.get("status") == "running"
    return not job.done


def draw_job(layout, job, status_text, cancel: str, *, job_name: str | None = None, cancel_text: str | None = None,
             lines=None, limit: int | None = None) -> bool:
    """While ``job`` runs: its progress bar with ``status_text(state)`` (cut to ``limit`` characters), the
    labels ``lines(state)`` returns, and the Cancel button (operator ``cancel``; ``job_name`` fills the shared
    ``ssgi.cancel_job``'s ``job``). Returns True when it drew, i.e. the job runs and the panel stops there."""
    if not job_running(job):
        return False
    st = job_state(job)
    text = status_text(st)
    layout.progress(factor=float(st.get("progress", 0.0)), type="BAR", text=text[:limit] if limit else text)
    for line in (lines(st) if lines else ()):
        layout.label(text=line)
    kw = {"icon": "CANCEL"}
    if cancel_text is not None:
        kw["text"] = cancel_text
    op = layout.operator(cancel, **kw)
    if job_name is not None:
        op.job = job_name
    return True


def draw_error(layout, job, limit: int = 120) -> bool:
    """The error message of a job that failed (status "error"), as an ERROR label; True when it drew."""
    st = job_state(job)
    if st.get("status") != "error":
        return False
    layout.label(text=(st.get("message") or "error")[:limit], icon="ERROR")
    return True
