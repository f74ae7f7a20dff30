"""UI panels: draw state, never compute.

``draw_job`` is the one way a panel shows a running background job (progress bar with ``jobs.status_text``,
lines under it, the one Cancel button ``ssgi.cancel_job``); ``job_running`` and ``draw_error`` go with it.
``JobPanel`` is the shape of a feature panel around one job: its settings (greyed out while the job runs),
then the job's progress, or the start button and how the last run ended."""
from __future__ import annotations

from ..ssgi_addon.runtime import jobs


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


def job_running(job) -> bool:
    """True while ``job`` (a ``jobs.Job`` or None) runs."""
    return job is not None and not job.done


def draw_job(layout, job, lines=None, limit: int | None = None) -> bool:
    """While ``job`` runs: its progress bar with ``jobs.status_text`` (cut to ``limit`` characters), the labels
    ``lines(state)`` returns, and Cancel. Returns True when it drew, i.e. the job runs and the panel stops there."""
    if not job_running(job):
        return False
    st = job.state
    text = jobs.status_text(st)
    layout.progress(factor=float(st.get("progress") or 0.0), type="BAR", text=text[:limit] if limit else text)
    for line in (lines(st) if lines else ()):
        layout.label(text=line)
    layout.operator("ssgi.cancel_job", icon="CANCEL").job = job.name
    return True


def draw_error(layout, job, limit: int = 120) -> bool:
    """The error message of a job that failed (status "error"), as an ERROR label; True when it drew."""
    if job is None or job.state.get("status") != "error":
        return False
    layout.label(text=(job.state.get("message") or "error")[:limit], icon="ERROR")
    return True


class JobPanel(SSGISubPanel):
    """Mixin for a feature panel around the job ``job_name``: ``draw_settings(layout, settings)`` (disabled
    while the job runs), then ``draw_job`` with ``job_lines`` (the bar's text cut to ``text_limit``), or the
    ``start_op`` button (``start_icon``) and, after a run, ``draw_outcome(layout, job)`` (an error, cut to
    ``error_limit`` characters, is drawn instead)."""
    job_name = ""
    start_op = ""
    start_icon = "PLAY"
    text_limit = 140
    error_limit = 120

    @staticmethod
    def job_lines(state) -> list[str]:
        return []

    def draw_settings(self, layout, settings) -> None:
        pass

    cancelled_text = "Cancelled"

    def draw_outcome(self, layout, job) -> None:
        """How the last run ended: ``cancelled_text``, or ``draw_result`` of a completed run's result."""
        st = job.state["status"]
        if st == "cancelled":
            layout.label(text=self.cancelled_text, icon="INFO")
        elif st == "done" and job.result:
            self.draw_result(layout, job.result)

    def draw_result(self, layout, result: dict) -> None:
        pass

    def draw(self, context):
        layout = self.layout
        s = getattr(context.scene, "ssgi", None)
        if s is None:
            return
        job = jobs.get(self.job_name)
        col = layout.column()
        col.enabled = not job_running(job)
        self.draw_settings(col, s)
        if draw_job(layout, job, lines=self.job_lines, limit=self.text_limit):
            return
        layout.operator(self.start_op, icon=self.start_icon)
        if job is not None and not draw_error(layout, job, limit=self.error_limit):
            self.draw_outcome(layout, job)
