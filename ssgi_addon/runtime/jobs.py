"""Background jobs for the UI: a worker thread that never touches bpy, and a main-thread pump.

The worker reports through a queue; ``pump()`` drains it on the main thread and copies the latest state into
``Job.state`` (a plain dict the panels draw). In the Blender app a ``bpy.app.timers`` callback calls
``pump()``; in the bpy module timers never fire, so tests call ``pump()`` themselves.
"""
from __future__ import annotations

import queue
import threading
import time
import traceback
from typing import Callable

_JOBS: dict[str, "Job"] = {}


class Cancelled(Exception):
    pass


class Job:
    """One background job. ``target(job)`` runs in a thread; it calls ``job.report(**state)`` and checks
    ``job.cancelled`` (or calls ``job.check_cancel()``) at least once per unit of work."""

    def __init__(self, name: str, target: Callable[["Job"], dict | None], on_done: Callable[["Job"], None] | None = None):
        self.name = name
        self._target = target
        self._on_done = on_done
        self._queue: queue.Queue = queue.Queue()
        self._cancel = threading.Event()
        self.state: dict = {"status": "starting", "progress": 0.0, "message": ""}
        self.result: dict | None = None
        self.error: str | None = None
        self.done = False
        self.started = time.time()
        self.thread = threading.Thread(target=self._run, name=f"ssgi-{name}", daemon=True)

    # --- worker side (no bpy here) ---
    @property
    def cancelled(self) -> bool:
        return self._cancel.is_set()

    def check_cancel(self) -> None:
        if self._cancel.is_set():
            raise Cancelled()

    def report(self, **state) -> None:
        self._queue.put(("state", state))

    def _run(self) -> None:
        try:
            res = self._target(self)
            self._queue.put(("done", res or {}))
        except Cancelled:
            self._queue.put(("cancelled", None))
        except Exception as e:  # reported to the UI, never raised into Blender's main loop
            from ...model.errors import UserError
            msg = str(e) if isinstance(e, UserError) else f"{type(e).__name__}: {e}\n{traceback.format_exc()}"
            self._queue.put(("error", msg))

    # --- main-thread side ---
    def start(self) -> "Job":
        if self.name in _JOBS and not _JOBS[self.name].done:
            raise RuntimeError(f"a {self.name} job is already running")
        _JOBS[self.name] = self
        self.state["status"] = "running"
        self.thread.start()
        return self

    def cancel(self) -> None:
        self._cancel.set()

    def pump(self) -> bool:
        """Drain the queue into ``state``; returns True while the job is still running."""
        while True:
            try:
                kind, payload = self._queue.get_nowait()
            except queue.Empty:
                break
            if kind == "state":
                self.state.update(payload)
            else:
                self.done = True
                if kind == "done":
                    self.result = payload
                    self.state.update(status="done", progress=1.0)
                elif kind == "cancelled":
                    self.state.update(status="cancelled")
                else:
                    self.error = payload
                    self.state.update(status="error", message=payload.splitlines()[0] if payload else "error")
                if self._on_done:
                    self._on_done(self)
        return not self.done

    def wait(self, timeout: float | None = None) -> None:
        """Block until the worker ends, pumping (for tests and the command line)."""
        end = None if timeout is None else time.time() + timeout
        while self.pump():
            if end is not None and time.time() > end:
                raise TimeoutError(f"job {self.name} still running after {timeout} s")
            time.sleep(0.02)


def get(name: str) -> Job | None:
    return _JOBS.get(name)


def pump_all() -> bool:
    """Pump every job; returns True while any is running."""
    running = False
    for j in list(_JOBS.values()):
        running = j.pump() or running
    return running


def _timer() -> float | None:
    running = pump_all()
    try:
        import bpy
        for win in bpy.context.window_manager.windows:
            for area in win.screen.areas:
                if area.type in ("PROPERTIES", "VIEW_3D", "NODE_EDITOR"):
                    area.tag_redraw()
    except Exception:
        pass
    return 0.25 if running else None


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
