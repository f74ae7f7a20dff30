"""Scenes built by script for tests, benchmarks and the results page: the artist test set (``scenes.artist``), the
held-out set (``scenes.heldout``) and the animated shots (``scenes.shots``). Deterministic (no randomness), saved
as .blend files.

The still scenes are split in two (docs/heldout_scenes.md):

- ``TUNING``: the artist test set. Score it as often as you like; it has been scored after every change, so
  changes are tuned to it.
- ``HELD_OUT``: scenes of the kinds SSGI is known to lose on, that no training room resembles. Score them only
  before a change is resolved (kept or dropped), never while tuning it, so that they stay a fair test.

``builder(name)`` is the module that builds a scene of either set (its ``build(name, size)``, ``save``, ``NAMES``).
Importing this package does not import bpy: the builders are imported when asked for.

Not part of the extension: blender_manifest.toml's [build] leaves scenes/ out of the zip. Importing the package
makes the checkout importable as the package ``ssgi`` (as cli.py does), so run a module from the repo root:

    .venv/bin/python -m scenes.artist --out DIR
    .venv/bin/python -m scenes.heldout --out DIR
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

TUNING = ("living_room", "studio", "exterior", "cornell_emissive", "closed_room")  # scenes.artist.NAMES
HELD_OUT = ("kitchen", "neon_room", "product_shot", "furnished_room", "staircase", "bathroom")  # scenes.heldout.NAMES
_MODULES = {"artist": TUNING, "heldout": HELD_OUT}


def builder(name: str):
    """The module that builds still scene ``name`` (``scenes.artist`` for TUNING, ``scenes.heldout`` for
    HELD_OUT), imported now (it imports bpy)."""
    import importlib
    for module, names in _MODULES.items():
        if name in names:
            return importlib.import_module(f"{__name__}.{module}")
    raise ValueError(f"{name!r}: no such scene; tuning: {', '.join(TUNING)}; held out: {', '.join(HELD_OUT)}")


def empty_scene():
    """Blender reset to factory settings with an empty file; its scene."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene
