"""Background jobs for the UI: one Job interface, three drivers, a registry by name.

- ``StepJob``: work on Blender's main thread (it renders: bpy is not thread-safe), one unit per ``step()``. The
  work is a generator: its first ``yield`` ends the setup (``start()`` runs up to it, so bad settings raise
  there), each later ``yield`` ends one unit and hands a dict of state; its ``return`` value is the result.
  The modal operator's timer (ops.JobSteps) or a test calls ``step()``; a cancel throws ``Cancelled`` into
  the generator at its current ``yield`` (between units), where it may catch it and return a summary.
- ``ThreadJob``: ``target(job)`` runs in a worker thread that never touches bpy; it calls ``job.report(**state)``
  and checks ``job.cancelled`` / ``job.check_cancel()`` once per unit. ``pump()`` (main thread) copies the
  reports into ``state``.
- ``ChildJob``: a process started by runtime/launcher.py, watched by a worker thread: progress lines become
  state, ``cancel()`` ends its whole process group within ``launcher.POLL_S``, stdout's JSON is the result.

Every job has one ``state`` dict that the panels draw, with the common keys ``status`` (starting, running,
done, cancelled, error), ``progress`` (0..1), ``message``, ``eta_s``, ``result`` and ``error``; ``status_text``
is the one line made from them. ``on_done(job)`` runs on the main thread when a job ends. In the Blender app
a ``bpy.app.timers`` callback calls ``pump_all()``; in the bpy module timers never fire, so tests pump.
"""
from __future__ import annotations

import queue
import threading
import time
import traceback
from typing import Callable

from ...model.errors import UserError

_JOBS: dict[str, "Job"] = {}
ENDED = ("done", "cancelled", "error")


class Cancelled(Exception):
    pass


class Busy(UserError):
    """A job of that name is running already."""


def _message(e: BaseException) -> str:
    return str(e) if isinstance(e, UserError) else f"{type(e).__name__}: {e}\n{traceback.format_exc()}"


class Job:
    """What every driver shares: the state, cancel, the registry, the end."""

    def __init__(self, name: str, on_done: Callable[["Job"], None] | None = None, title: str | None = None,
                 status_bar: bool = False):
        self.name = name
        self.title = title or f"SSGI {name}"
        self.status_bar = status_bar  # shown in the status bar while it runs (panels.status_bar)
        self._on_done = on_done
        self._cancel = threading.Event()
        self.state: dict = {"status": "starting", "progress": 0.0, "message": "", "eta_s": None,
                            "result": None, "error": None}
        self.started = time.time()

    @property
    def result(self) -> dict | None:
        return self.state["result"]

    @property
    def error(self) -> str | None:
        return self.state["error"]

    @property
    def done(self) -> bool:
        return self.state["status"] in ENDED

    @property
    def running(self) -> bool:
        return self.state["status"] == "running"

    @property
    def cancelled(self) -> bool:
        """Cancel was asked for (the work should stop at its next check)."""
        return self._cancel.is_set()

    def check_cancel(self) -> None:
        if self._cancel.is_set():
            raise Cancelled()

    def cancel(self) -> None:
        self._cancel.set()

    def start(self) -> "Job":
        other = _JOBS.get(self.name)
        if other is not None and other is not self and not other.done:
            raise Busy(f"a {self.name} job is already running")
        self._begin()  # may raise (a step job's setup): then it is not registered
        _JOBS[self.name] = self
        return self

    def _begin(self) -> None:
        self.state["status"] = "running"

    def _finish(self, status: str, result: dict | None = None, error: str | None = None) -> None:
        self.state.update(status=status, result=result, error=error, eta_s=None)
        if status == "done":
            self.state["progress"] = 1.0
        elif status == "error":
            self.state["message"] = error.splitlines()[0] if error else "error"
        if self._on_done:
            self._on_done(self)

    def pump(self) -> bool:
        """Main thread: bring ``state`` up to date; True while the job runs."""
        return not self.done

    def wait(self, timeout: float | None = None) -> None:
        """Block until the job ends, pumping (tests and the command line)."""
        end = None if timeout is None else time.time() + timeout
        while self.pump():
            if end is not None and time.time() > end:
                raise TimeoutError(f"job {self.name} still running after {timeout} s")
            time.sleep(0.02)


class StepJob(Job):
    """Main-thread steps (see module doc). ``steps`` is the generator of the work."""

    def __init__(self, name: str, steps, **kw):
        super().__init__(name, **kw)
        self._gen = steps

    def _begin(self) -> None:
        try:
            self.state.update(next(self._gen) or {})
        except StopIteration as e:  # no units at all
            super()._begin()
            self._finish("done", e.value)
            return
        super()._begin()

    def step(self) -> bool:
        """Run the next unit (or wind up after a cancel); True while units remain. An error ends the job
        (status "error") and is raised again for the caller to report."""
        if self.done:
            return False
        try:
            upd = self._gen.throw(Cancelled()) if self.cancelled else next(self._gen)
        except StopIteration as e:
            self._finish("cancelled" if self.cancelled else "done", e.value)
            return False
        except Cancelled:
            self._finish("cancelled")
            return False
        except Exception as e:
            self._gen.close()
            self._finish("error", error=_message(e))
            raise
        if self.cancelled:  # the work went on after Cancelled: stop it here
            self._gen.close()
            self._finish("cancelled")
            return False
        self.state.update(upd or {})
        return True

    def run(self) -> dict | None:
        """Every unit, here and now (scripts, ``blender -b``); returns the result."""
        while self.step():
            pass
        return self.result

    def wait(self, timeout: float | None = None) -> None:
        """Step until the job ends (nothing else advances a step job)."""
        end = None if timeout is None else time.time() + timeout
        while self.step():
            if end is not None and time.time() > end:
                raise TimeoutError(f"job {self.name} still running after {timeout} s")


class ThreadJob(Job):
    """A worker thread (see module doc): ``target(job)`` returns the result dict."""

    def __init__(self, name: str, target: Callable[["ThreadJob"], dict | None], **kw):
        super().__init__(name, **kw)
        self._target = target
        self._queue: queue.Queue = queue.Queue()
        self.thread = threading.Thread(target=self._run, name=f"ssgi-{name}", daemon=True)

    # --- worker side (no bpy here)
    def report(self, **state) -> None:
        self._queue.put(("state", state))

    def _run(self) -> None:
        try:
            res = self._target(self)
            self._queue.put(("done", res or {}))
        except Cancelled:
            self._queue.put(("cancelled", None))
        except Exception as e:  # reported to the UI, never raised into Blender's main loop
            self._queue.put(("error", _message(e)))

    # --- main-thread side
    def _begin(self) -> None:
        super()._begin()
        self.thread.start()

    def pump(self) -> bool:
        while not self.done:
            try:
                kind, payload = self._queue.get_nowait()
            except queue.Empty:
                break
            if kind == "state":
                self.state.update(payload)
            elif kind == "error":
                self._finish("error", error=payload)
            else:
                self._finish(kind, payload)
        return not self.done


class ChildJob(ThreadJob):
    """A child process (see module doc). ``result(outcome)`` makes the result from the ended child (default:
    its stdout JSON); ``what`` names it in the error; log lines starting with ``message_lines`` become the
    message (prefix removed; "" for every line), the others go to ``state["log"]``."""

    def __init__(self, name: str, cmd: list[str], env: dict | None = None, what: str | None = None,
                 result: Callable | None = None, merge_output: bool = False, message_lines: str | None = None,
                 **kw):
        super().__init__(name, self._watch, **kw)
        self.cmd = list(cmd)
        self.env = env
        self.what = what or name
        self._result = result
        self.merge_output = merge_output
        self.message_lines = message_lines
        self.proc = None
        self.phases: list[str] = []  # every phase the child reported, in order

    def _on_progress(self, d: dict) -> None:
        if d.get("phase") and (not self.phases or self.phases[-1] != d["phase"]):
            self.phases.append(d["phase"])
        self.report(phases=list(self.phases), **d)

    def _on_line(self, line: str) -> None:
        p = self.message_lines
        if p is not None and line.startswith(p):
            self.report(message=line[len(p):], log=line)
        else:
            self.report(log=line)

    def _watch(self, _job) -> dict | None:
        from . import launcher
        self.proc = launcher.start(self.cmd, env=self.env, merge_output=self.merge_output)
        out = launcher.watch(self.proc, on_progress=self._on_progress, on_line=self._on_line,
                             should_cancel=lambda: self.cancelled)
        if out.cancelled:
            raise Cancelled()
        out.check(self.what)
        return self._result(out) if self._result else (out.json() or {})


def get(name: str) -> Job | None:
    return _JOBS.get(name)


def running(name: str) -> bool:
    """True while a job of this name runs."""
    j = _JOBS.get(name)
    return j is not None and not j.done


def pump_all() -> bool:
    """Pump every job; returns True while any is running."""
    busy = False
    for j in list(_JOBS.values()):
        busy = j.pump() or busy
    return busy


def running_jobs() -> list[Job]:
    return [j for j in _JOBS.values() if not j.done]


def _duration(s: float) -> str:
    return f"{s / 60:.1f} min" if s >= 60 else f"{s:.0f} s"


def status_text(state: dict) -> str:
    """The one line of a job's state: ``phase · NN% · message · ETA``."""
    parts = []
    if state.get("phase"):
        parts.append(str(state["phase"]))
    parts.append(f"{100 * float(state.get('progress') or 0.0):.0f}%")
    if state.get("message"):
        parts.append(str(state["message"]))
    if state.get("eta_s") is not None:
        parts.append(f"ETA {_duration(float(state['eta_s']))}")
    return " · ".join(parts)


def _timer() -> float | None:
    busy = pump_all()
    try:
        import bpy
        for win in bpy.context.window_manager.windows:
            for area in win.screen.areas:
                if area.type in ("PROPERTIES", "VIEW_3D", "NODE_EDITOR", "STATUSBAR"):
                    area.tag_redraw()
    except Exception:
        pass
    return 0.25 if busy else None


def ensure_timer() -> None:
    """Start the UI timer that pumps jobs (a no-op in the bpy module, where timers never fire)."""
    import bpy
    if not bpy.app.timers.is_registered(_timer):
        bpy.app.timers.register(_timer, first_interval=0.1, persistent=True)


def shutdown() -> None:
    """On unregister: ask running jobs to stop and take the UI timer away, so nothing of the add-on keeps
    running after it is disabled. Workers never touch bpy, so a worker finishing later is harmless."""
    for j in _JOBS.values():
        if not j.done:
            j.cancel()
    try:
        import bpy
        if bpy.app.timers.is_registered(_timer):
            bpy.app.timers.unregister(_timer)
    except Exception:
        pass
