"""Import rules of the package, checked by reading every module's imports (ast), not by running them:

- model/ (bpy-free, the learning half) imports neither Blender (bpy, bmesh, mathutils, gpu, bpy_extras) nor
  the package's ssgi_addon/, ops/, panels/ or cli;
- ssgi_addon/ imports neither ops/ nor panels/ (operators and panels sit on top of it, never below).

Every import counts: absolute and relative, at module level and inside functions, ``import_module`` and
``__import__`` with a constant name. A relative import is resolved against the file's place in the package
(the checkout root is the package ``ssgi``; installed it is ``bl_ext.<repo>.ssgi``).
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from ..conftest import ROOT

BLENDER = ("bpy", "bmesh", "mathutils", "gpu", "bpy_extras")
FORBIDDEN = {  # top folder of the importing module -> what it must not import (package paths or Blender)
    "model": BLENDER + ("ssgi_addon", "ops", "panels", "cli"),
    "ssgi_addon": ("ops", "panels"),
}
PACKAGE_DIRS = ("model", "ssgi_addon", "ops", "panels")
PACKAGE_NAMES = ("ssgi",)  # an absolute import of the package itself, as a checkout loads it


def package_files(root: Path) -> list[Path]:
    """The package's modules: the root's __init__.py and cli.py and every .py under its folders."""
    files = [root / f for f in ("__init__.py", "cli.py") if (root / f).is_file()]
    for d in PACKAGE_DIRS:
        files += sorted((root / d).rglob("*.py"))
    return [f for f in files if "__pycache__" not in f.parts]


def _module_parts(root: Path, f: Path) -> list[str]:
    parts = list(f.relative_to(root).with_suffix("").parts)
    return parts[:-1] if parts[-1] == "__init__" else parts


def imports_of(root: Path, f: Path) -> list[tuple[int, str]]:
    """(line, target) for every import in ``f``: a package path relative to the root ("model.channels",
    "ops") or an outside module ("bpy", "numpy"), each dotted."""
    parts = _module_parts(root, f)
    pkg = parts if f.name == "__init__.py" else parts[:-1]  # the package a relative import starts from
    out = []

    def absolute(name: str) -> str:
        first, _, rest = name.partition(".")
        return rest if first in PACKAGE_NAMES and rest else name

    for node in ast.walk(ast.parse(f.read_text(), str(f))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, absolute(a.name)) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                base = absolute(node.module or "")
            else:
                if node.level - 1 > len(pkg):
                    out.append((node.lineno, f"<relative import above the package root: level {node.level}>"))
                    continue
                here = pkg[:len(pkg) - (node.level - 1)]
                base = ".".join(here + ([node.module] if node.module else []))
            # `from X import a`: a may be a module inside X or a name in X; X.a covers both
            out += [(node.lineno, base if a.name == "*" else f"{base}.{a.name}" if base else a.name)
                    for a in node.names]
        elif (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
              and isinstance(node.args[0].value, str)
              and (getattr(node.func, "id", None) == "__import__" or getattr(node.func, "attr", None) == "import_module"
                   or getattr(node.func, "id", None) == "import_module")):
            out.append((node.lineno, absolute(node.args[0].value)))
    return out


def violations(root: Path) -> list[str]:
    """Each broken rule as ``file:line: imports target``."""
    bad = []
    for f in package_files(root):
        rel = f.relative_to(root)
        banned = FORBIDDEN.get(rel.parts[0]) if len(rel.parts) > 1 else None
        for line, target in imports_of(root, f):
            if target.startswith("<"):
                bad.append(f"{rel}:{line}: {target}")
            elif banned and any(target == b or target.startswith(b + ".") for b in banned):
                bad.append(f"{rel}:{line}: imports {target}")
    return bad


def test_the_package_keeps_its_import_rules():
    assert len(package_files(ROOT)) > 40  # the walk does see the package
    assert violations(ROOT) == []


def _tree(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        p = root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    for d in PACKAGE_DIRS:
        (root / d).mkdir(exist_ok=True)
        (root / d / "__init__.py").touch()
    return root


def test_a_broken_rule_is_found_wherever_the_import_hides(tmp_path):
    root = _tree(tmp_path, {
        "__init__.py": "from .ops import bake_ops\nfrom .panels import main_panel\n",  # the root may import all
        "cli.py": "import bpy\n",
        "model/ok.py": "import numpy\nfrom . import channels\nfrom .learn import network\nfrom ..model import errors\n",
        "model/top.py": "import bpy\n",
        "model/learn/__init__.py": "",
        "model/learn/deep.py": "def f():\n    from mathutils import Vector\n    from ...ssgi_addon.blender import room\n",
        "model/learn/nested.py": "class A:\n    def m(self):\n        from ... import cli\n",
        "model/absolute.py": "import ssgi.panels.node_panel\nfrom ssgi.ops import node_ops\n",
        "model/strings.py": "import importlib\nm = importlib.import_module('ssgi.ssgi_addon.props')\nb = __import__('bmesh')\n",
        "model/climb.py": "from .... import x\n",
        "ssgi_addon/fine.py": "import bpy\nfrom ..model import channels\nfrom .runtime import jobs\n",
        "ssgi_addon/pipeline/up.py": "from ...ops import node_ops\n",
        "ssgi_addon/pipeline/__init__.py": "from ... import panels\n",
        "ops/ok.py": "import bpy\nfrom ..ssgi_addon import props\nfrom ..panels import main_panel\n",
    })
    got = violations(root)
    want = [
        "model/absolute.py:1: imports panels.node_panel",
        "model/absolute.py:2: imports ops.node_ops",
        "model/climb.py:1: <relative import above the package root: level 4>",
        "model/learn/deep.py:2: imports mathutils.Vector",
        "model/learn/deep.py:3: imports ssgi_addon.blender.room",
        "model/learn/nested.py:3: imports cli",
        "model/strings.py:2: imports ssgi_addon.props",
        "model/strings.py:3: imports bmesh",
        "model/top.py:1: imports bpy",
        "ssgi_addon/pipeline/__init__.py:1: imports panels",
        "ssgi_addon/pipeline/up.py:1: imports ops.node_ops",
    ]
    assert sorted(got) == want, got


@pytest.mark.parametrize("rel,text,target", [
    ("model/a.py", "from . import b\n", "model.b"),
    ("model/learn/__init__.py", "from . import fit\n", "model.learn.fit"),
    ("model/learn/fit.py", "from ..dataset import folder\n", "model.dataset.folder"),
    ("ssgi_addon/commands/render.py", "from ...model.errors import UserError\n", "model.errors.UserError"),
    ("__init__.py", "from .ssgi_addon.runtime import deps\n", "ssgi_addon.runtime.deps"),
])
def test_relative_imports_resolve_against_the_files_place(tmp_path, rel, text, target):
    f = tmp_path / rel
    f.parent.mkdir(parents=True, exist_ok=True)
    f.write_text(text)
    assert target in [t for _, t in imports_of(tmp_path, f)]
