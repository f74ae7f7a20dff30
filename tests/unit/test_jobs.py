"""ssgi_addon/runtime: the child launcher and the three job drivers, with tiny Python children (no Blender,
bpy-free, a few seconds)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from ssgi.model.errors import UserError
from ssgi.ssgi_addon.runtime import jobs, launcher, progress

from ..conftest import ROOT

PY = sys.executable


def _py(code: str) -> list[str]:
    return [PY, "-c", textwrap.dedent(code)]


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        stat = open(f"/proc/{pid}/stat").read()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


def _wait_gone(pids, timeout=5.0) -> list[int]:
    end = time.time() + timeout
    while time.time() < end and any(_alive(p) for p in pids):
        time.sleep(0.02)
    return [p for p in pids if _alive(p)]


# a child that starts a grandchild in its group, says both pids (as progress), then prints nothing for a minute
_SILENT = f"""
import subprocess, sys, time
sys.path.insert(0, {str(ROOT)!r})
import cli; cli.load_package()
from ssgi.ssgi_addon.runtime import progress
g = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
progress.emit(progress=0.5, phase="wait", message="sleeping", grandchild=g.pid)
time.sleep(60)
"""


def test_progress_lines_round_trip(capsys):
    progress.emit(progress=0.25, phase="bake", eta_s=3)
    line = capsys.readouterr().err
    assert progress.parse(line) == {"progress": 0.25, "phase": "bake", "eta_s": 3}
    assert progress.parse("report: progress 0.5 eta 3s: x") is None and progress.parse("SSGI_PROGRESS [1]") is None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups via /proc")
def test_child_job_that_prints_nothing_is_cancelled_within_a_second_with_its_whole_group():
    job = jobs.ChildJob("t-silent", _py(_SILENT), what="sleeper").start()
    t = time.time()
    while job.pump() and job.state.get("grandchild") is None and time.time() - t < 60:
        time.sleep(0.02)
    assert job.state["phase"] == "wait" and job.state["message"] == "sleeping" and job.phases == ["wait"]
    assert jobs.status_text(job.state) == "wait · 50% · sleeping"
    grandchild, pgid = job.state["grandchild"], job.proc.pid
    assert os.getpgid(grandchild) == pgid != os.getpgid(0)  # its own group, the grandchild in it
    time.sleep(0.5)  # the child is silent now: cancel must not wait for a line
    t = time.time()
    job.cancel()
    job.wait(timeout=3)
    assert time.time() - t < 1.0
    assert job.state["status"] == "cancelled" and job.result is None and job.error is None
    assert launcher.group_members(pgid) == [] and not _alive(grandchild)


def test_child_that_dies_reports_its_stderr_tail():
    code = """
    import sys
    for i in range(30):
        print(f"line {i}", file=sys.stderr)
    print("EGL noise", file=sys.stderr)
    print("the real reason", file=sys.stderr)
    sys.exit(3)
    """
    job = jobs.ChildJob("t-dies", _py(code), what="tiny child").start()
    job.wait(timeout=30)
    assert job.state["status"] == "error"
    assert job.state["message"] == "tiny child exited with status 3: the real reason"
    assert "line 29" in job.error and "line 5" not in job.error and "EGL" not in job.error  # a tail, no noise
    with pytest.raises(launcher.ChildFailed, match="exited with status 3: the real reason"):
        launcher.run(_py(code)).check("tiny child")
    assert issubclass(launcher.ChildFailed, UserError)


def test_child_job_result_is_its_stdout_json_and_log_lines_are_kept_apart():
    code = """
    import json, sys
    print("warming up", file=sys.stderr)
    print("SSGI_PROGRESS " + json.dumps({"progress": 0.5, "message": "half"}), file=sys.stderr)
    print(json.dumps({"ok": True, "model": "m.pt"}, indent=1))
    """
    job = jobs.ChildJob("t-json", _py(code)).start()
    job.wait(timeout=30)
    assert job.state["status"] == "done" and job.result == {"ok": True, "model": "m.pt"}
    assert job.state["message"] == "half" and job.state["log"] == "warming up" and job.state["progress"] == 1.0
    job = jobs.ChildJob("t-lines", _py("print('a'); print('pip: b')"), merge_output=True, message_lines="pip: ").start()
    job.wait(timeout=30)
    assert job.state["message"] == "b" and job.state["log"] == "pip: b"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux only")
def test_a_child_dies_with_its_parent_even_when_the_parent_is_killed():
    parent = f"""
    import sys, time
    sys.path.insert(0, {str(ROOT)!r})
    import cli; cli.load_package()
    from ssgi.ssgi_addon.runtime import launcher
    p = launcher.start([sys.executable, "-c", "import time; time.sleep(60)"])
    print(p.pid, flush=True)
    time.sleep(60)
    """
    par = subprocess.Popen(_py(parent), stdout=subprocess.PIPE, text=True)
    child = None
    try:
        child = int(par.stdout.readline())
        assert _alive(child) and os.getpgid(child) == child  # its own group: not killed by the parent's group
        par.send_signal(signal.SIGKILL)
        par.wait()
        assert _wait_gone([child]) == []
    finally:
        for p in ([par.pid] if par.poll() is None else []) + ([child] if child and _alive(child) else []):
            os.kill(p, signal.SIGKILL)


def test_step_job_runs_units_cancels_between_them_and_returns_its_summary():
    log = []

    def work(n):
        log.append("setup")
        done = 0
        try:
            for i in range(n):
                yield {"done": done, "todo": n, "message": f"{done}/{n}"}
                done += 1
                log.append(f"unit {i}")
        except jobs.Cancelled:
            return {"status": "cancelled", "done": done}
        finally:
            log.append("cleanup")
        return {"status": "done", "done": done}

    job = jobs.StepJob("t-steps", work(3)).start()
    assert log == ["setup"] and job.state["status"] == "running" and jobs.running("t-steps")
    with pytest.raises(jobs.Busy, match="already running"):
        jobs.StepJob("t-steps", work(1)).start()
    assert job.step() is True and log == ["setup", "unit 0"] and job.state["message"] == "1/3"
    job.cancel()
    assert job.step() is False and log == ["setup", "unit 0", "cleanup"]
    assert job.state["status"] == "cancelled" and job.result == {"status": "cancelled", "done": 1}
    job = jobs.StepJob("t-steps", work(2)).start()
    assert job.run() == {"status": "done", "done": 2} and job.state["status"] == "done"

    def bad():
        yield {}
        raise UserError("unit failed")

    def bad_setup():
        raise UserError("bad settings")
        yield {}

    job = jobs.StepJob("t-bad", bad()).start()
    with pytest.raises(UserError):
        job.step()
    assert job.state["status"] == "error" and job.state["message"] == "unit failed"
    with pytest.raises(UserError, match="bad settings"):
        jobs.StepJob("t-bad-setup", bad_setup()).start()
    assert jobs.get("t-bad-setup") is None  # a job whose setup failed is not registered


def test_thread_job_reports_cancels_and_fails_through_pump():
    def target(job):
        for i in range(1000):
            job.report(progress=i / 1000, message=f"step {i}")
            job.check_cancel()
            time.sleep(0.005)
        return {"n": 1000}

    job = jobs.ThreadJob("t-thread", target).start()
    while job.pump() and job.state["progress"] == 0.0:
        time.sleep(0.01)
    job.cancel()
    job.wait(timeout=5)
    assert job.state["status"] == "cancelled" and job.result is None

    def fails(job):
        raise UserError("no dataset")

    ended = []
    job = jobs.ThreadJob("t-thread", fails, on_done=ended.append).start()
    job.wait(timeout=5)
    assert job.state["status"] == "error" and job.error == "no dataset" and ended == [job]
