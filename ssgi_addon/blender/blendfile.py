"""Open a user's .blend in this process, with errors that name the file and say what is wrong.

The one way the command-line tools (fit, render, report, bake) open a file they were given: a missing path, a
folder, a file this process may not read and a file Blender cannot load are each a ``UserError`` (exit 2)
that starts with the argument and the path, e.g. ``--blend shot.blend: no such .blend file``.
"""
from __future__ import annotations

import os
from pathlib import Path

from ...model.errors import UserError


def check_blend(path, arg: str | None = "--blend") -> Path:
    """The absolute path of ``path`` (``~`` expanded) when it is a readable file, else a UserError naming it:
    missing, a folder (or not a regular file), or not readable. ``arg`` starts the message (None: the path only)."""
    p = Path(path).expanduser()
    where = f"{arg} {path}" if arg else f"{path}"
    if not p.exists():
        raise UserError(f"{where}: no such .blend file")
    if p.is_dir():
        raise UserError(f"{where}: is a folder, not a .blend file")
    if not p.is_file():
        raise UserError(f"{where}: not a regular file")
    if not os.access(p, os.R_OK):
        raise UserError(f"{where}: not readable (permission denied)")
    return p.resolve()


def open_blend(path, arg: str | None = "--blend"):
    """Open ``path`` in place of the current file (``load_ui=False``) and return its active scene. Errors as
    ``check_blend``; a file Blender fails to load: ``not a readable .blend file (Blender could not open it: ...)``."""
    import bpy

    p = check_blend(path, arg)
    try:
        bpy.ops.wm.open_mainfile(filepath=str(p), load_ui=False)
    except RuntimeError as e:
        why = (str(e).strip().splitlines() or ["unknown error"])[-1]
        where = f"{arg} {path}" if arg else f"{path}"
        raise UserError(f"{where}: not a readable .blend file (Blender could not open it: {why})") from None
    return bpy.context.scene


def pick_scene(path, name: str | None, arg: str | None = "--scene"):
    """The scene ``name`` of the file just opened (None: its active scene), else a UserError naming the
    file and listing its scenes."""
    import bpy

    if not name:
        return bpy.context.scene
    scene = bpy.data.scenes.get(name)
    if scene is None:
        where = f"{arg} {name}" if arg else f"scene {name!r}"
        raise UserError(f"{where}: no such scene in {path}; scenes: {', '.join(s.name for s in bpy.data.scenes)}")
    return scene
