"""The CLI subcommands: thin adapters, argparse -> a stage's config -> the stage (ssgi_addon/pipeline/) -> its
summary. Each module defines ``register_cli(subparsers)``, which adds its subparser(s) (their defaults read
from the stage's config) and sets ``func=run(args) -> dict``. Heavy imports (torch, bpy data work) happen
inside ``run``, so that ``--help`` and the bpy-only commands stay fast and work without torch."""
from __future__ import annotations

import shlex
import sys


def modules() -> tuple:
    """The command modules, in the order of ``cli.py --help``."""
    from . import bake, demo, fit, info, randomize, render, report, train
    return (info, randomize, bake, demo, train, render, fit, report)


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
