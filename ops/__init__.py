"""Thin Operator classes: parse the user's intent, call ssgi_addon / model, report.

``TimerSteps`` is the shared modal loop of the operators that must work on the main thread (they render):
invoked from the UI they do one unit of work per timer tick, with progress in the window manager, and Esc
stops between units."""
from __future__ import annotations

TICK_S = 0.05


def redraw(context) -> None:
    """Tag every area of the current screen for redraw (the panels show the progress)."""
    for area in context.screen.areas if context.screen else ():
        area.tag_redraw()


def cancel_state(op, state: dict, what: str) -> set:
    """The body of a Cancel operator for a main-thread job whose state is a plain dict (the bake's and the
    render's ``STATE``): ask it to stop after the current unit, or warn that ``what`` is not running."""
    if state.get("status") != "running":
        op.report({"WARNING"}, f"no {what} is running")
        return {"CANCELLED"}
    state["cancel"] = True
    return {"FINISHED"}


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
