"""Thin Operator classes: check the user's input, call ssgi_addon (pipeline, runtime), report.

The mixins here are the two ways an operator runs a background job (ssgi_addon/runtime/jobs.py):

- ``JobSteps`` (on ``TimerSteps``, the modal loop): a main-thread ``StepJob`` (Bake Dataset, Render SSGI). Invoked
  from the UI it does one unit per timer tick, with progress in the window manager; Esc or ``ssgi.cancel_job``
  stops between units. Run from a script (``execute``) it runs to the end.
- ``StartsJob``: a worker-thread or child-process job (Train, Fit to Scene, Report, Install): start it and
  return; the UI timer pumps it and the panels draw it.
"""
from __future__ import annotations

from ..model.errors import UserError
from ..ssgi_addon.runtime import deps, jobs

TICK_S = 0.05


def redraw(context) -> None:
    """Tag every area of the current screen for redraw (the panels show the progress)."""
    for area in context.screen.areas if context.screen else ():
        area.tag_redraw()


class TimerSteps:
    """Mixin for a modal ``bpy.types.Operator`` (put it first among the bases). The operator implements:

    - ``step_work(context) -> (more, done)``: one unit of work; ``more`` False when all is done, ``done`` the
      units done so far (the window manager's progress);
    - ``stop_request()``: Esc was pressed; stop after the current unit;
    - ``steps_finished(context)``: after the last unit (report the summary);
    - ``steps_failed(context, message)`` (optional): after an exception, before the ERROR report.

    ``invoke`` calls ``start_steps(context, total)`` and returns what it returns."""

    _timer = None

    def start_steps(self, context, total: int) -> set:
        wm = context.window_manager
        wm.progress_begin(0, max(1, int(total)))
        self._timer = wm.event_timer_add(TICK_S, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self.stop_request()
            return self._tick(context)
        if event.type == "TIMER" and event.timer is self._timer:
            return self._tick(context)
        return {"PASS_THROUGH"}  # the UI stays usable between units (the panel's Cancel button)

    def _tick(self, context):
        try:
            more, done = self.step_work(context)
        except Exception as e:  # UserError, or a bug: stop cleanly (timer, progress) and say what happened
            from ..model.errors import UserError
            msg = str(e) if isinstance(e, UserError) else f"{type(e).__name__}: {e}"
            self.end_steps(context)
            self.steps_failed(context, msg)
            self.report({"ERROR"}, msg)
            return {"CANCELLED"}
        context.window_manager.progress_update(int(done))
        redraw(context)
        if more:
            return {"RUNNING_MODAL"}
        self.end_steps(context)
        self.steps_finished(context)
        return {"FINISHED"}

    def end_steps(self, context) -> None:
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()

    def steps_failed(self, context, message: str) -> None:
        pass


class JobSteps(TimerSteps):
    """Mixin for an operator that runs a ``jobs.StepJob`` (put it first among the bases). The operator
    implements ``make_job(context)`` (the job, not started; a UserError says what is wrong) and
    ``summary_text(result)``; ``job_finished(context, job)`` is optional. The job's state holds ``done`` and
    ``todo`` (its units)."""

    _job = None

    def execute(self, context):
        try:
            job = self.make_job(context).start()
            job.run()
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, self.summary_text(job.result))
        return {"FINISHED"}

    def invoke(self, context, event):
        import bpy
        if bpy.app.background:
            return self.execute(context)
        try:
            self._job = self.make_job(context).start()
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return self.start_steps(context, self._job.state.get("todo", 1))

    # TimerSteps: one unit of the job per timer tick
    def step_work(self, context):
        return self._job.step(), self._job.state.get("done", 0)

    def stop_request(self):
        self._job.cancel()

    def steps_finished(self, context):
        res = self._job.result
        self.report({"INFO"}, self.summary_text(res) if res else f"{self.bl_label}: {self._job.state['status']}")
        self.job_finished(context, self._job)

    def job_finished(self, context, job) -> None:
        pass


class StartsJob:
    """Mixin for an operator that starts a background job and returns at once (put it first among the
    bases). Class attributes: ``job_name`` (greys the button out while that job runs) and ``needs_torch``
    (refused without PyTorch). ``start_job(context)`` starts it and returns the INFO line; a
    UserError (or OSError, or a bpy RuntimeError) is reported and nothing runs."""

    job_name = ""
    needs_torch = False

    @classmethod
    def poll(cls, context):
        return context.scene is not None and not jobs.running(cls.job_name)

    def execute(self, context):
        if self.needs_torch and not deps.torch_available():
            self.report({"ERROR"}, "PyTorch is not installed: install it in Preferences > Add-ons > SSGI")
            return {"CANCELLED"}
        try:
            info = self.start_job(context)
        except (UserError, OSError, RuntimeError) as e:  # RuntimeError: a bpy call (saving the copy) failed
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        jobs.ensure_timer()
        self.report({"INFO"}, info)
        return {"FINISHED"}
