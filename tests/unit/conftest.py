"""The unit lane (``make test-fast``): bpy-free tests that run in well under a minute.

A unit test never imports bpy (nor bmesh, mathutils, gpu ...) and never renders. Two checks hold the lane
to that, so that a test (or a module it imports) that starts needing Blender fails here, with a pointer to
tests/blender/, instead of slowly turning the fast lane into a second Blender lane:

- in this process: after each test, no Blender module may have appeared in ``sys.modules``;
- in the Python subprocesses a test starts: ``PYTHONPATH`` carries a ``sitecustomize`` whose meta-path
  finder lets ``importlib.util.find_spec("bpy")`` work (Blender's extension tool is found that way) but makes
  ``import bpy`` raise ImportError.

The in-process check is exact when the lane runs alone, as ``make test-fast`` and ``make test`` run it;
when one pytest run also collects tests/blender, bpy is imported at collection and the check is skipped.
"""
from __future__ import annotations

import os
import sys

import pytest

BLENDER_MODULES = frozenset({"bpy", "_bpy", "bmesh", "mathutils", "gpu", "bpy_extras", "addon_utils", "aud",
                             "blf", "idprop", "imbuf"})

# sitecustomize of the unit lane's subprocesses: the spec is found, loading it fails.
_HIDE_BPY = f'''
import importlib.abc, sys
_NAMES = {sorted(BLENDER_MODULES)!r}

class _Refuse(importlib.abc.Loader):
    def create_module(self, spec):
        raise ImportError(f"{{spec.name}} is not importable in the unit lane (bpy-free): move the test to tests/blender")

    def exec_module(self, module):
        raise ImportError(module.__name__)

class _HideBlender:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] not in _NAMES:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(name, path, target)
            if spec is not None:
                spec.loader = _Refuse()
                return spec
        return None

sys.meta_path.insert(0, _HideBlender())
'''


def blender_modules() -> set[str]:
    """The Blender modules imported in this process."""
    return {m for m in sys.modules if m.split(".")[0] in BLENDER_MODULES}


_AT_START = blender_modules()  # empty when this lane runs alone


@pytest.fixture(scope="session")
def _hide_bpy_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("hide_bpy")
    (d / "sitecustomize.py").write_text(_HIDE_BPY)
    return d


@pytest.fixture(autouse=True)
def _bpy_free(request, monkeypatch, _hide_bpy_dir):
    """Fail a unit test that imports a Blender module in this process; hide bpy from its subprocesses."""
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (str(_hide_bpy_dir), os.environ.get("PYTHONPATH"))
                                                     if p))
    before = blender_modules()
    yield
    if _AT_START or before:
        return  # another lane imported bpy in this process already: nothing to tell
    new = blender_modules()
    if new:
        pytest.fail(f"{request.node.nodeid} imported Blender modules ({', '.join(sorted(new)[:4])}, ...): the unit "
                    "lane is bpy-free; move the test to tests/blender", pytrace=False)
