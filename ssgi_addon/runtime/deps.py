"""torch inside the Blender app: detection, the extension's own site-packages, and the pip installer.

Blender's bundled Python has no torch, and 4 GB of wheels can't ship in an extension; the SSGI node runs the
bundled onnxruntime instead (model/infer/onnx.py) when the model has an ONNX export, so only training, fit and
report need torch. The add-on
preferences offer "Install Python dependencies", which pip-installs TORCH_REQUIREMENT into
``bpy.utils.extension_path_user(<package>, path="site-packages")``. Features that need torch check
``torch_status()`` and say so in their panels; randomizing and baking never need it.
"""
from __future__ import annotations

import importlib
import os
import shlex
import sys
from pathlib import Path

TORCH_REQUIREMENT = "torch==2.13.0"
SITE_DIR_NAME = "site-packages"
EXTENSION_ID = "ssgi"  # the manifest's id

_status: tuple[bool, str] | None = None


def extension_package() -> str | None:
    """``bl_ext.<repo>.ssgi`` of this extension: itself when installed; when loaded from a checkout (the
    command line in a Blender binary), an installed and enabled copy of it, if there is one."""
    from .. import root_package
    pkg = root_package()
    if pkg.startswith("bl_ext."):
        return pkg
    import bpy
    for repo in bpy.context.preferences.extensions.repos:
        if repo.enabled and repo.directory and (Path(repo.directory) / EXTENSION_ID / "blender_manifest.toml").is_file():
            return f"bl_ext.{repo.module}.{EXTENSION_ID}"
    return None


def deps_dir(create: bool = False) -> Path | None:
    """The extension's private site-packages folder, or None when there is no installed extension."""
    pkg = extension_package()
    if pkg is None:
        return None
    import bpy
    try:
        d = bpy.utils.extension_path_user(pkg, path=SITE_DIR_NAME, create=create)
    except Exception:
        return None
    return Path(d) if d else None


def add_to_path(path: Path | None = None) -> Path | None:
    """Put the private site-packages first on sys.path, if it exists. Returns it."""
    d = path if path is not None else deps_dir()
    if d is not None and Path(d).is_dir():
        if str(d) in sys.path:
            sys.path.remove(str(d))
        sys.path.insert(0, str(d))
        importlib.invalidate_caches()  # a folder already on sys.path may have new packages since
    return d


def torch_status(refresh: bool = False) -> tuple[bool, str]:
    """(available, version-or-reason). Cached; ``refresh`` tries the import again."""
    global _status
    if _status is None or refresh:
        try:
            import torch
            _status = (True, str(torch.__version__))
        except Exception as e:  # ImportError, or a broken install (missing CUDA libs, ...)
            _status = (False, f"torch is not importable ({type(e).__name__}: {e})")
    return _status


def torch_available() -> bool:
    return torch_status()[0]


def onnxruntime_status() -> tuple[bool, str]:
    """(importable, "version, providers" or the reason): the bundled runtime of the SSGI node."""
    try:
        import onnxruntime as ort
        return True, f"{ort.__version__} ({', '.join(p.replace('ExecutionProvider', '') for p in ort.get_available_providers())})"
    except Exception as e:
        return False, f"onnxruntime is not importable ({type(e).__name__}: {e})"


def missing_message(feature: str) -> str:
    return (f"{feature} needs PyTorch, which this Blender's Python lacks: open Preferences > Add-ons > SSGI "
            f"and press 'Install Python dependencies' (the SSGI node needs it only for a model without an ONNX "
            f"export beside it: Export ONNX where torch is installed).")


def pip_command(target: Path, requirement: str = TORCH_REQUIREMENT, python: str | None = None,
                extra_args: str | list[str] = ()) -> list[str]:
    """The pip command the installer runs (no network access happens here). ``extra_args`` (a shell-style
    string or a list) goes before the requirement, e.g. ``--index-url https://download.pytorch.org/whl/cpu``."""
    if isinstance(extra_args, str):
        try:
            extra_args = shlex.split(extra_args)
        except ValueError as e:
            from ...model.errors import UserError
            raise UserError(f"extra pip arguments {extra_args!r}: {e}") from None
    reqs = shlex.split(requirement) if requirement.strip() else []
    if not reqs:
        from ...model.errors import UserError
        raise UserError("the package to install is empty; the default is " + TORCH_REQUIREMENT)
    return [python or sys.executable, "-m", "pip", "install", "--disable-pip-version-check", "--no-input",
            "--upgrade", "--target", str(target), *extra_args, *reqs]


def start_install(target=None, requirement: str = TORCH_REQUIREMENT, extra_args: str = ""):
    """Start the pip install of ``requirement`` (torch) into the extension's folder as a child job ("deps",
    runtime/launcher.py: cancel ends pip and whatever it started). Its output lines are the job's message; on
    success the folder goes first on sys.path and the torch status is checked again."""
    from . import jobs
    target = target or deps_dir(create=True)
    if target is None:
        from ...model.errors import UserError
        raise UserError("not running as an installed extension: no user folder to install into")
    cmd = pip_command(target, requirement, extra_args=extra_args)

    def done(job) -> None:
        if job.result is not None:
            add_to_path(target)
            ok, info = torch_status(refresh=True)
            job.result["torch"] = info if ok else None
            job.state["message"] = f"installed into {target}; torch {info}" if ok else f"installed, but {info}"

    job = jobs.ChildJob("deps", cmd, env=dict(os.environ, PYTHONNOUSERSITE="1"), what="pip", merge_output=True,
                        message_lines="", result=lambda _o: {"target": str(target)}, on_done=done,
                        title="SSGI install")
    job.state["message"] = "running: " + " ".join(cmd[2:])
    return job.start()
