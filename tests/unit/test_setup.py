"""Cheap invariants of the environment setup (the venv is never reinstalled here)."""
from __future__ import annotations

import os
import re
import subprocess
from importlib import metadata

from ..conftest import ROOT


def _pins(path) -> dict[str, str]:
    out = {}
    for line in (ROOT / path).read_text().splitlines():
        line = line.split("#")[0].strip()
        if not line:
            continue
        m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==([^\s;]+)", line)
        assert m, f"{path}: {line!r} is not pinned with =="
        name = m.group(1).lower().replace("_", "-")
        assert name not in out, f"{path}: {name} twice"
        out[name] = m.group(2)
    return out


def test_lock_pins_what_ci_tested():
    lock = _pins("requirements.lock")
    assert lock["bpy"] == "5.0.1"
    assert lock["torch"].split("+")[0] == "2.13.0"
    assert lock["numpy"] == "1.26.4" and lock["openexr"] == "3.5.3"
    # every direct requirement is in the lock at the same version
    for name, ver in _pins("requirements.txt").items():
        assert name in lock and lock[name].split("+")[0] == ver.split("+")[0], name


def test_venv_matches_the_lock():
    for name, ver in _pins("requirements.lock").items():
        assert metadata.version(name) == ver, name


def test_ci_runs_exactly_make_test():
    run = ROOT / ".ci" / "run"
    assert os.access(run, os.X_OK)
    cmds = [l.strip() for l in run.read_text().splitlines() if l.strip() and not l.strip().startswith("#")]
    assert cmds[-1] == "make test"
    assert all(c.startswith(("set ", "cd ")) for c in cmds[:-1]), cmds


def _make_n(*targets: str, extra=()) -> str:
    p = subprocess.run(["make", "-n", *extra, *targets], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    return p.stdout


def test_make_targets():
    assert "cli.py demo --out out/demo" in _make_n("demo")
    assert "-m pytest" in _make_n("test")
    assert "scripts/blender_ext.py build" in _make_n("build")
    assert "scripts/blender_ext.py validate" in _make_n("validate")
    # demo and test create the environment first when it is missing or out of date
    for target in ("demo", "test"):
        assert "bash scripts/setup.sh" in _make_n(target, extra=("-W", "requirements.lock")), target


def test_setup_script_checks_system_packages():
    assert subprocess.run(["bash", "-n", "scripts/setup.sh"], cwd=ROOT).returncode == 0
    # on a set-up machine nothing is missing; an unknown package is reported as missing
    p = subprocess.run(["bash", "scripts/setup.sh", "--print-missing"], cwd=ROOT, capture_output=True, text=True)
    assert p.returncode == 0 and p.stdout.split() == [], p.stdout
    env = dict(os.environ, SSGI_EXTRA_SYSTEM_PACKAGES="ssgi-no-such-package")
    p = subprocess.run(["bash", "scripts/setup.sh", "--print-missing"], cwd=ROOT, capture_output=True, text=True, env=env)
    assert p.stdout.split() == ["ssgi-no-such-package"]
    # bpy's shared object finds every library it links against
    import importlib.util
    so = os.path.join(importlib.util.find_spec("bpy").submodule_search_locations[0], "__init__.so")
    ldd = subprocess.run(["ldd", so], capture_output=True, text=True).stdout
    assert "not found" not in ldd, [l for l in ldd.splitlines() if "not found" in l]
