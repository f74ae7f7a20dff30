#!/usr/bin/env python3
"""Run Blender's own extension tool (``blender_ext.py``, shipped inside the bpy wheel) without importing bpy.

    .venv/bin/python scripts/blender_ext.py validate .
    .venv/bin/python scripts/blender_ext.py build --source-dir . --output-dir dist

``build`` creates the output folder first (the tool itself fails when it is missing).
"""
from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path


def tool_path() -> Path:
    """Path of blender_ext.py inside the installed bpy wheel (found without importing bpy)."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("blender_ext: the bpy module is not installed in this Python; run `make setup`")
    for loc in spec.submodule_search_locations:
        hits = sorted(Path(loc).glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
        if hits:
            return hits[-1]
    sys.exit(f"blender_ext: no */scripts/addons_core/bl_pkg/cli/blender_ext.py under {spec.submodule_search_locations}")


def main(argv: list[str]) -> int:
    if argv and argv[0] == "build" and "--output-dir" in argv:
        os.makedirs(argv[argv.index("--output-dir") + 1], exist_ok=True)
    os.execv(sys.executable, [sys.executable, str(tool_path()), *argv])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
