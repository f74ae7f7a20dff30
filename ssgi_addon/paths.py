"""The one rule that turns a path property of the scene (``scene.ssgi.dataset_dir``, ``train_out``, ``report_out``,
``fit_out``, ``model_path``, ...) into an absolute path, for every operator: ``//`` is relative to the saved
.blend file (an unsaved file has no folder: a UserError says to save it or choose an absolute path), ``~`` is
the home folder, and any other relative path is refused (it would depend on Blender's working directory)."""
from __future__ import annotations

import os

import bpy

from ..model.errors import UserError


def scene_path(value: str, what: str) -> str | None:
    """``value`` as an absolute path without a trailing separator; None when it is empty."""
    if not value:
        return None
    if value.startswith("//") and not bpy.data.filepath:
        raise UserError(f"{what} {value!r}: save the .blend file first, or choose an absolute path")
    out = os.path.expanduser(bpy.path.abspath(value))
    if not os.path.isabs(out):
        raise UserError(f"{what} {value!r}: save the .blend file first, or choose an absolute path")
    return out.rstrip("/\\") or "/"


def required_path(value: str, what: str) -> str:
    """``scene_path`` for a setting that must not be empty."""
    out = scene_path(value, what)
    if out is None:
        raise UserError(f"{what}: not set; choose a path (an absolute one, or // beside the saved .blend file)")
    return out
