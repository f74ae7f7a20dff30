#!/usr/bin/env python3
"""SSGI command line. Runs two ways, with the same subcommands:

    .venv/bin/python cli.py SUBCOMMAND ...                      (the bpy module)
    blender --background --python cli.py -- SUBCOMMAND ...     (a Blender binary)

Progress goes to stderr; ``--json`` prints a machine-readable summary on stdout. A user error exits with
status 2 and a message that names the argument, file or value and what is wrong.

The subcommands are the modules that ``ssgi_addon/commands/__init__.py:modules()`` lists; each defines
``register_cli(subparsers)``, which adds its subparser(s) and sets ``func=run(args) -> dict``.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.util
import json
import os
import sys
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parent
PACKAGE = "ssgi"



def load_package(name: str = PACKAGE):
    """Import the repository root as the package ``ssgi`` so that its relative imports work outside Blender.

    Inside Blender the extension is imported as ``bl_ext.<repo>.ssgi``; from a checkout it is this.
    """
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def in_blender_binary() -> bool:
    """True when run by a Blender binary (``blender --python cli.py``), False with the bpy module."""
    bpy = sys.modules.get("bpy")  # a Blender binary has imported bpy before running this script
    return bpy is not None and not getattr(bpy.app, "module", True)


def _add_extension_deps_to_path() -> str | None:
    """In a Blender binary, make importable what the add-on's "Install Python dependencies" put into the
    installed extension's user folder (torch). ``SSGI_DEPS_DIR`` names another folder. The venv needs none."""
    d = os.environ.get("SSGI_DEPS_DIR")
    if d:
        if d not in sys.path:
            sys.path.insert(0, d)
        return d
    if not in_blender_binary():
        return None
    try:
        load_package()
        from ssgi.ssgi_addon.runtime import deps
        found = deps.add_to_path()
        return str(found) if found else None
    except Exception as e:  # never fatal: commands that need torch say so themselves
        print(f"cli.py: warning: could not add the extension's dependency folder to sys.path ({e})", file=sys.stderr)
        return None


def _argv() -> list[str]:
    argv = sys.argv
    if "--" in argv:  # blender --background --python cli.py -- ARGS
        return argv[argv.index("--") + 1:]
    if in_blender_binary() or Path(argv[0]).name.startswith("blender"):
        return []  # everything else on Blender's command line is Blender's own
    return argv[1:]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cli.py",
        description="SSGI: learn path-traced global illumination from EEVEE G-buffers.",
    )
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND")
    sub.required = True
    load_package()
    from ssgi.ssgi_addon import commands  # the package load_package() put in sys.modules
    for mod in commands.modules():
        mod.register_cli(sub)
    for p in sub.choices.values():
        if not any(a.dest == "json" for a in p._actions):
            p.add_argument("--json", action="store_true", help="print a machine-readable summary on stdout")
    return parser


def _fail(args, code: int, msg: str) -> int:
    print(f"cli.py {args.command}: error: {msg}", file=sys.stderr)
    if getattr(args, "json", False):
        print(json.dumps({"ok": False, "error": msg}))
    return code


def main(argv: list[str] | None = None) -> int:
    _add_extension_deps_to_path()
    load_package()
    from ssgi.model import errors
    parser = build_parser()
    argv = _argv() if argv is None else argv
    args, unparsed = parser.parse_known_args(argv)
    if getattr(args, "needs_blender", False):  # a Blender command where bpy is missing: its options do not matter
        args.unparsed = unparsed
    elif unparsed:
        args = parser.parse_args(argv)  # argparse's own error for what it does not know
    from ssgi.model.dataset.exrio import stdout_to_stderr
    try:
        # with --json, stdout holds only the summary: what Blender's C code prints meanwhile (Cycles' "CUEW
        # initialization failed", "Read blend: ...") goes to stderr
        with stdout_to_stderr() if getattr(args, "json", False) else contextlib.nullcontext():
            result = args.func(args) or {}
    except errors.UserError as e:
        return _fail(args, 2, str(e))
    except KeyboardInterrupt:
        print(f"cli.py {args.command}: interrupted; completed work is kept", file=sys.stderr)
        return 130
    except ImportError as e:  # a command that needs Blender, where bpy is missing: what to install, in one line
        from ssgi.ssgi_addon import commands
        if not commands.is_blender_import(e):
            traceback.print_exc()
            return _fail(args, 1, f"{type(e).__name__}: {e}")
        return _fail(args, 2, commands.needs_blender(args.command, e))
    except Exception as e:  # a Blender binary would print this and exit 0: make it a failure in both ways
        traceback.print_exc()
        return _fail(args, 1, f"{type(e).__name__}: {e}")
    if getattr(args, "json", False):
        print(json.dumps({"ok": True, **result}, default=str, indent=1))
    return 0


if __name__ == "__main__":
    # In a Blender binary, SystemExit ends Blender with this status (argparse's own exits included).
    sys.exit(main())
