"""The CLI subcommands: each module defines ``register_cli(subparsers)``, which adds its subparser(s) and sets
``func=run(args) -> dict``. Heavy imports (torch, bpy data work) happen inside ``run``, so that ``--help`` and
the bpy-only commands stay fast and work without torch."""
from __future__ import annotations


def modules() -> tuple:
    """The command modules, in the order of ``cli.py --help``."""
    from . import fit, info, render, report, train
    from ..blender import room
    from ..pipeline import bake, demo
    return (info, room, bake, demo, train, render, fit, report)
