"""Scenes built by script for tests, benchmarks and the results page: the artist test set (``scenes.artist``) and
the animated shots (``scenes.shots``). Deterministic (no randomness), saved as .blend files.

Not part of the extension: blender_manifest.toml's [build] leaves scenes/ out of the zip. Importing the package
makes the checkout importable as the package ``ssgi`` (as cli.py does), so run a module from the repo root:

    .venv/bin/python -m scenes.artist --out DIR
    .venv/bin/python -m scenes.shots --out DIR
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import cli  # noqa: E402

cli.load_package()


def empty_scene():
    """Blender reset to factory settings with an empty file; its scene."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene
