"""The CLI subcommands: thin adapters, argparse -> a stage's config -> the stage (ssgi_addon/pipeline/) -> its
summary. Each module defines ``register_cli(subparsers)``, which adds its subparser(s) (their defaults read
from the stage's config) and sets ``func=run(args) -> dict``. Heavy imports (torch, bpy data work) happen
inside ``run``, so that ``--help`` and the bpy-only commands stay fast and work without torch."""
from __future__ import annotations

import importlib
import shlex
import sys

# the command modules, in the order of ``cli.py --help``, and the subcommands each adds
COMMANDS = (("info", ("info",)), ("randomize", ("randomize",)), ("bake", ("bake",)),
            ("dataset", ("verify", "merge", "preview")), ("demo", ("demo",)),
            ("train", ("train", "baseline", "predict", "export", "curves", "bench")), ("render", ("render",)), ("setup", ("setup",)),
            ("fit", ("fit",)), ("report", ("report",)))
BLENDER_MODULES = frozenset({"bpy", "_bpy", "bmesh", "mathutils", "gpu", "bpy_extras", "addon_utils"})


def is_blender_import(e: BaseException) -> bool:
    """True for an ImportError of one of Blender's modules (bpy, mathutils, ...): a command that needs Blender, run
    where there is none."""
    if not isinstance(e, ImportError):
        return False
    name = (getattr(e, "name", None) or "").split(".")[0]
    return name in BLENDER_MODULES or any(f"{m}" in str(e).split() or f"'{m}'" in str(e) for m in BLENDER_MODULES)


def needs_blender(command: str, e: BaseException) -> str:
    """The one-line error of a command that needs Blender where bpy cannot be imported."""
    return (f"{command} needs Blender, and this Python cannot import bpy ({type(e).__name__}: {e}). Install Blender's "
            f"module (Python 3.11: pip install bpy==5.0.1, as requirements.lock pins it) or run it in Blender: "
            f"blender --background --python cli.py -- {command} ...; train, export, predict, baseline, curves, bench, "
            f"verify, merge, preview and info run without Blender")


class NeedsBlender:
    """Stands in for a command module that cannot be imported without Blender: its subcommands are listed and each
    answers with ``needs_blender``."""

    def __init__(self, names: tuple, error: ImportError):
        self.names, self.error = names, error

    def register_cli(self, sub) -> None:
        import argparse
        for n in self.names:
            p = sub.add_parser(n, help="(needs Blender: bpy is not importable here)", add_help=False)
            p.add_argument("rest", nargs=argparse.REMAINDER)
            p.set_defaults(func=self.run, needs_blender=True)  # cli.py lets its options through unparsed

    def run(self, args):
        from ...model.errors import UserError
        args.json = "--json" in (args.rest or []) + list(getattr(args, "unparsed", []))
        raise UserError(needs_blender(args.command, self.error))


def modules() -> tuple:
    """The command modules, in the order of ``cli.py --help``; where bpy is missing, a ``NeedsBlender`` for each that
    imports it."""
    out = []
    for name, subcommands in COMMANDS:
        try:
            out.append(importlib.import_module(f"{__name__}.{name}"))
        except ImportError as e:
            if not is_blender_import(e):
                raise
            out.append(NeedsBlender(subcommands, e))
    return tuple(out)


def command_line() -> str:
    """This process's command line, as recorded in what a command writes (checkpoints, reports)."""
    return " ".join(shlex.quote(a) for a in [sys.executable] + sys.argv)


def progress_sink(args):
    """With ``--progress`` (a command the UI runs as a child): a ``progress(dict)`` callback that writes the
    JSON progress lines of ssgi_addon/runtime/progress.py; without it, None."""
    if not getattr(args, "progress", False):
        return None
    from ..runtime import progress
    return lambda d: progress.emit(**d)
