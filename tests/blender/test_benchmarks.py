"""The scripts in benchmarks/ start through benchmarks/_bootstrap.py (the checkout as package ``ssgi``): each
parses its arguments (--help) and is named by the documentation it feeds. The measurements themselves are
minutes long and are not run here."""
from __future__ import annotations

import subprocess
import sys

import pytest

from ..conftest import ROOT, clean

SCRIPTS = sorted(p.name for p in (ROOT / "benchmarks").glob("*.py") if p.name != "_bootstrap.py")


def test_the_tool_scripts_live_in_benchmarks_and_docs_holds_no_python():
    assert {"node_bench.py", "ref_target.py", "results.py"} <= set(SCRIPTS)
    assert not list((ROOT / "docs").rglob("*.py"))


@pytest.mark.parametrize("module", ["scenes.artist", "scenes.heldout", "scenes.shots"])
def test_each_scene_module_runs_from_the_repo_root(module):
    p = subprocess.run([sys.executable, "-m", module, "--help"], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert p.returncode == 0 and "--out" in p.stdout, clean(p.stderr)[-2000:]


@pytest.mark.parametrize("name", SCRIPTS)
def test_each_script_starts_and_parses_its_arguments(name):
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / name), "--help"], capture_output=True, text=True,
                       timeout=120, cwd=ROOT / "benchmarks")  # from another folder too: the bootstrap finds the checkout
    assert p.returncode == 0 and "usage:" in p.stdout, clean(p.stderr)[-2000:]


def test_each_script_is_named_by_the_documentation_it_feeds():
    """benchmarks/ keeps the scripts behind documented numbers only: each is named in README.md or docs/."""
    text = (ROOT / "README.md").read_text() + "".join(p.read_text() for p in (ROOT / "docs").rglob("*.md"))
    assert not [n for n in SCRIPTS if f"benchmarks/{n}" not in text]
