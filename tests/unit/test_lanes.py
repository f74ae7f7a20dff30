"""The test lanes: `make test-fast` runs tests/unit alone, `make test` runs every lane, and the unit lane's
conftest fails a test that imports bpy (in the test's process or in a Python it starts)."""
from __future__ import annotations

import os
import subprocess
import sys

from ..conftest import ROOT


def _make_n(*targets: str) -> str:
    # -o: never remake the environment stamp here, only print the recipes
    p = subprocess.run(["make", "-n", "-o", ".venv/.ssgi-setup-done", *targets], cwd=ROOT, capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    return p.stdout


def test_make_test_fast_runs_the_unit_lane_and_make_test_runs_every_lane():
    fast = _make_n("test-fast")
    assert "-m pytest -q tests/unit" in fast and "tests/blender" not in fast and "hard_cases" not in fast
    full = _make_n("test")
    for lane in ("tests/unit", "tests/blender", "tests/hard_cases"):
        assert lane in full, lane
    # every test file lives in a lane
    loose = sorted(p.name for p in (ROOT / "tests").glob("test_*.py"))
    assert loose == [], loose
    for lane in ("unit", "blender", "hard_cases"):
        assert list((ROOT / "tests" / lane).glob("test_*.py")), lane


_PROBE_TESTS = '''
import subprocess, sys

def test_plain():
    pass

def test_subprocess_cannot_import_bpy_but_finds_it():
    p = subprocess.run([sys.executable, "-c", "import bpy"], capture_output=True, text=True)
    assert p.returncode != 0 and "unit lane" in p.stderr, p.stderr
    p = subprocess.run([sys.executable, "-c", "import importlib.util as u; print(u.find_spec('bpy').origin)"],
                       capture_output=True, text=True)
    assert p.returncode == 0 and "bpy" in p.stdout, p.stderr

def test_imports_bpy():
    import bpy  # noqa: F401
'''


def test_unit_lane_fails_a_test_that_imports_bpy(tmp_path):
    """A copy of the unit lane's conftest over three probe tests: the one importing bpy fails with a message
    pointing to tests/blender; the others pass (bpy is found, but not importable, in a subprocess)."""
    lane = tmp_path / "lane"
    lane.mkdir()
    (lane / "conftest.py").write_text((ROOT / "tests" / "unit" / "conftest.py").read_text())
    (lane / "test_probe.py").write_text(_PROBE_TESTS)
    env = dict(os.environ)
    env.pop("PYTHONPATH")  # this lane's own hiding of bpy: off, so that the probe's process can import bpy
    p = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(lane)],
                       cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    out = p.stdout + p.stderr
    assert p.returncode == 1, out
    assert "3 passed, 1 error" in out and "ERROR at teardown of test_imports_bpy" in out, out
    assert "test_imports_bpy imported Blender modules (" in out and "move the test to tests/blender" in out, out
