"""The one way SSGI starts a child process (the fit, the report, pip, the fit's view baker).

    proc = start(cmd, env=cli_env())                 # own process group, dies with this process
    outcome = watch(proc, on_progress=..., should_cancel=...)   # progress lines, cancel, stdout, stderr tail
    outcome.check("cli.py fit")                      # a non-zero exit raises ChildFailed with the stderr tail
    summary = outcome.json()                         # the JSON summary the child printed on stdout

- Process group: ``start`` puts the child in a new session (``new_group=True``) so that ``stop_group`` ends
  it and everything it started at once. A child started by such a child (the fit's baker) stays in its
  parent's group (``new_group=False``), so one group kill reaches both.
- Dies with its parent: on Linux the child asks the kernel for SIGTERM when the thread that started it ends
  (``PR_SET_PDEATHSIG``), even when the parent is SIGKILLed. Start and watch a child from the same thread.
- Progress: ``SSGI_PROGRESS {json}`` lines on stderr (runtime/progress.py) go to ``on_progress``; every other
  line is log text (``on_line``, and the tail kept for the error message).
- Cancel: ``should_cancel()`` is polled every ``POLL_S`` whether or not the child prints; when true the whole
  group gets SIGTERM, and SIGKILL whatever is left after ``grace_s``.

bpy-free except ``cli_command`` / ``cli_env``, which import bpy when called.
"""
from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from ...model.errors import UserError
from . import progress

POLL_S = 0.1
GRACE_S = 5.0
TAIL_LINES = 20
NOISE = ("EGL",)  # log lines of no interest (the bpy module's GL probing), kept out of the tail
ROOT = Path(__file__).resolve().parents[2]  # the extension root (cli.py is there)
_PR_SET_PDEATHSIG = 1


class ChildFailed(UserError):
    """A child process exited with a non-zero status; the message ends with the tail of its log."""


@dataclass
class Outcome:
    """How a child ended: exit status, whether it was cancelled, its stdout and the tail of its log."""
    returncode: int | None
    cancelled: bool = False
    stdout: str = ""
    tail: list[str] = field(default_factory=list)

    def check(self, what: str) -> "Outcome":
        """Raise ChildFailed when the child failed: first line ``WHAT exited with status N: <last log line>``,
        then the tail of its log."""
        if self.returncode != 0 and not self.cancelled:
            last = self.tail[-1] if self.tail else "(no output)"
            more = "\n".join(self.tail[:-1])
            raise ChildFailed(f"{what} exited with status {self.returncode}: {last}" + (f"\n{more}" if more else ""))
        return self

    def json(self) -> dict | None:
        """The JSON object the child printed on stdout (``cli.py ... --json``), or None."""
        text = self.stdout
        try:
            d = json.loads(text[text.index("{"):])
        except ValueError:
            return None
        return d if isinstance(d, dict) else None


def _pdeathsig():
    """libc's prctl, looked up before any fork (the child only calls it), or None where there is none."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def start(cmd: list[str], env: dict | None = None, new_group: bool = True, merge_output: bool = False,
          cwd=None) -> subprocess.Popen:
    """Start ``cmd`` with piped stdout and stderr (``merge_output``: stderr into stdout), text mode."""
    prctl = _pdeathsig()
    parent = os.getpid()

    def in_child() -> None:  # between fork and exec: no imports, no allocation to speak of
        if prctl is not None:
            prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
            if os.getppid() != parent:  # the parent died before the request took effect
                os.kill(os.getpid(), signal.SIGTERM)

    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT if merge_output else subprocess.PIPE,
                            text=True, errors="replace", env=env, cwd=cwd, start_new_session=new_group,
                            preexec_fn=in_child if prctl is not None else None)
    proc.ssgi_group = new_group and hasattr(os, "killpg")  # its pid is its process group's id
    return proc


def watch(proc: subprocess.Popen, on_progress=None, on_line=None, should_cancel=None, grace_s: float = GRACE_S,
          noise=NOISE) -> Outcome:
    """Follow ``proc`` until it ends or ``should_cancel()`` is true (then ``stop_group``). Lines of its log
    (stderr, or stdout with ``merge_output``) go to ``on_progress(dict)`` or ``on_line(str)``."""
    merged = proc.stderr is None
    log_pipe = proc.stdout if merged else proc.stderr
    lines: queue.Queue = queue.Queue()
    out_chunks: list[str] = []
    readers = [threading.Thread(target=lambda: [lines.put(l) for l in log_pipe] and None, daemon=True)]
    if not merged:
        readers.append(threading.Thread(target=lambda: out_chunks.append(proc.stdout.read()), daemon=True))
    for t in readers:
        t.start()
    tail: list[str] = []
    cancelled = False
    try:
        while True:
            if should_cancel is not None and should_cancel():
                cancelled = True
                break
            try:
                line = lines.get(timeout=POLL_S)
            except queue.Empty:
                if proc.poll() is not None and not readers[0].is_alive() and lines.empty():
                    break
                continue
            d = progress.parse(line)
            if d is not None:
                if on_progress is not None:
                    on_progress(d)
                continue
            line = line.rstrip()
            if not line.strip() or any(n in line for n in noise):
                continue
            tail.append(line)
            del tail[:-TAIL_LINES]
            if on_line is not None:
                on_line(line)
    finally:
        if cancelled or proc.poll() is None:  # cancelled, or a callback raised: leave nothing running
            stop_group(proc, grace_s)
    proc.wait()
    for t in readers:
        t.join(timeout=5)
    return Outcome(proc.returncode, cancelled, "".join(out_chunks), tail)


def run(cmd: list[str], env: dict | None = None, new_group: bool = True, merge_output: bool = False,
        **watch_kw) -> Outcome:
    """``start`` then ``watch`` (in this thread, as the parent-death signal needs)."""
    return watch(start(cmd, env=env, new_group=new_group, merge_output=merge_output), **watch_kw)


def group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes of process group ``pgid`` (Linux /proc; empty elsewhere)."""
    out = []
    for d in Path("/proc").glob("[0-9]*"):
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # state ppid pgrp ...
        if len(fields) > 2 and int(fields[2]) == pgid and fields[0] != "Z":
            out.append(int(d.name))
    return out


def _signal_group(proc: subprocess.Popen, sig) -> None:
    try:
        if getattr(proc, "ssgi_group", False):
            os.killpg(proc.pid, sig)  # works while any member lives, even after the leader has exited
        elif proc.poll() is None:  # in its parent's group (new_group=False), or no groups here: the child alone
            proc.send_signal(sig)
    except (ProcessLookupError, PermissionError):
        pass


def stop_group(proc: subprocess.Popen, grace_s: float = GRACE_S) -> None:
    """End ``proc`` and every member of its process group: SIGTERM at once, SIGKILL for what is still there
    after ``grace_s`` seconds, until no member is left (or 5 s more)."""
    pgid = proc.pid if getattr(proc, "ssgi_group", False) else -1
    _signal_group(proc, signal.SIGTERM)
    end = time.time() + grace_s
    while time.time() < end:
        if proc.poll() is not None and not group_members(pgid):
            return
        time.sleep(0.02)
    end = time.time() + 5.0
    while time.time() < end:
        _signal_group(proc, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()
        if proc.poll() is not None and not group_members(pgid):
            return
        time.sleep(0.05)


# ------------------------------------------------------------------------------------- cli.py as a child

def cli_command(*args: str) -> list[str]:
    """The command line that runs ``cli.py ARGS`` the way this process runs: the bpy module's Python, or the
    Blender binary in the background (the user's file is never touched: the child opens its own)."""
    import bpy
    cli = str(ROOT / "cli.py")
    if getattr(bpy.app, "module", True):
        return [sys.executable, cli, *args]
    return [bpy.app.binary_path, "--background", "--factory-startup", "--python", cli, "--", *args]


def cli_env() -> dict:
    """This environment, plus ``SSGI_DEPS_DIR`` naming the installed extension's dependency folder (torch),
    which cli.py puts on sys.path."""
    env = dict(os.environ)
    try:
        from . import deps
        d = deps.deps_dir()
        if d is not None and Path(d).is_dir():
            env.setdefault("SSGI_DEPS_DIR", str(d))
    except Exception:  # no bpy context (a child of a child): the inherited environment already says it
        pass
    return env
