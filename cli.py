#!/usr/bin/env python3
"""SSGI command line. Runs two ways, with the same subcommands:

    .venv/bin/python cli.py SUBCOMMAND ...                      (the bpy module)
    blender --background --python cli.py -- SUBCOMMAND ...     (a Blender binary)

Progress goes to stderr; ``--json`` prints a machine-readable summary on stdout. A user error exits with
status 2 and a message that names the argument, file or value and what is wrong.

Each subcommand lives beside the code it drives: a module listed in ``COMMAND_MODULES`` defines
``register_cli(subparsers)`` which adds its subparser(s) and sets ``func=run(args) -> dict``. Those modules
import torch and heavy things lazily, inside ``run``, so that ``--help`` and bpy-only commands stay fast and
work without torch.
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent
PACKAGE = "ssgi"

# package-relative modules that define register_cli(subparsers); order is the order in --help
COMMAND_MODULES = [
    "ssgi_addon.info_cli",
    "ssgi_addon.render_cli",
]


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


def _add_extension_deps_to_path() -> None:
    """In a Blender binary, make the dependencies installed by the add-on's installer importable."""
    d = os.environ.get("SSGI_DEPS_DIR")
    if d and d not in sys.path:
        sys.path.insert(0, d)
    try:
        pkg = load_package()
        from importlib import import_module
        deps = import_module(f"{pkg.__name__}.ssgi_addon.deps")
        deps.add_to_path()
    except Exception:
        pass


def _argv() -> list[str]:
    argv = sys.argv
    if "--" in argv:  # blender --background --python cli.py -- ARGS
        return argv[argv.index("--") + 1:]
    if Path(argv[0]).name.startswith("blender") or (len(argv) > 1 and argv[1] in ("-b", "--background")):
        return []
    return argv[1:]


def build_parser() -> argparse.ArgumentParser:
    pkg = load_package()
    parser = argparse.ArgumentParser(
        prog="cli.py",
        description="SSGI: learn path-traced global illumination from EEVEE G-buffers.",
    )
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND")
    sub.required = True
    for modname in COMMAND_MODULES:
        mod = importlib.import_module(f"{pkg.__name__}.{modname}")
        mod.register_cli(sub)
    for p in sub.choices.values():
        if not any(a.dest == "json" for a in p._actions):
            p.add_argument("--json", action="store_true", help="print a machine-readable summary on stdout")
    return parser


def main(argv: list[str] | None = None) -> int:
    _add_extension_deps_to_path()
    pkg = load_package()
    errors = importlib.import_module(f"{pkg.__name__}.model.errors")
    parser = build_parser()
    args = parser.parse_args(_argv() if argv is None else argv)
    try:
        result = args.func(args) or {}
    except errors.UserError as e:
        print(f"cli.py {args.command}: error: {e}", file=sys.stderr)
        if getattr(args, "json", False):
            print(json.dumps({"ok": False, "error": str(e)}))
        return 2
    except KeyboardInterrupt:
        print(f"cli.py {args.command}: interrupted; completed work is kept", file=sys.stderr)
        return 130
    if getattr(args, "json", False):
        print(json.dumps({"ok": True, **result}, default=str, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
