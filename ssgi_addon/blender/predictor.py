"""The model a scene renders with, as the add-on holds it: a cached Predictor per model file (reloaded when the
file changes), and the view-layer passes its channel spec needs. The render path, Set up SSGI and the demo
share the cache, so a model is loaded once per Blender session."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...model import channels as ch, cliargs
from ...model.errors import UserError
from . import node as ssgi_node

_PREDICTORS: dict = {}


def load_model(path: Path, runtime: str | None = None, device: str | None = None):
    """A cached predictor for ``path`` (reloaded when the file changes), in ``runtime``/on ``device``
    (model/infer/predictor.load_predictor; None: the add-on preferences', "auto" outside Blender's UI):
    onnxruntime with the .onnx beside the .pt where there is one, torch otherwise. UserError names a
    missing/bad file or what is missing to run it."""
    path = Path(path)
    fault = cliargs.model_file_fault(path)
    if fault:
        hint = " (the shipped default model)" if path == ssgi_node.DEFAULT_MODEL else ""
        raise UserError(f"{path}: {fault}{hint}; set the SSGI node's model or pass --model")
    from ...model.infer import predictor as infer
    threads = None
    try:
        from .. import preferences
        if preferences.prefs() is not None:
            threads = preferences.torch_threads()
            runtime = runtime or preferences.prefs().runtime.lower()
            device = device or preferences.prefs().device.lower()
    except Exception:
        threads = None
    runtime, device = runtime or "auto", device or "auto"
    key = (str(path.resolve()), path.stat().st_mtime_ns, runtime, device)
    pred = _PREDICTORS.get(key)
    if pred is None:
        try:
            pred = infer.load_predictor(path, num_threads=threads, runtime=runtime, device=device)
        except UserError as e:
            if "PyTorch" not in str(e):
                raise
            from ..runtime import deps
            raise UserError(deps.missing_message("The SSGI node") + f" ({e})") from None
        _PREDICTORS.clear()
        _PREDICTORS[key] = pred
    return pred


def forget_models() -> None:
    """Drop the cached predictors (after an export: the next render picks the runtime again)."""
    _PREDICTORS.clear()


def missing_passes(scene, spec) -> list[str]:
    """View-layer pass flags that ``spec`` needs and the first view layer (the one the passes come from)
    lacks."""
    vl = scene.view_layers[0]
    return [flag for flag in ch.required_passes(tuple(spec)) if not getattr(vl, flag, False)]


def pass_label(flag: str) -> str:
    """'use_pass_diffuse_direct' -> 'Diffuse Direct (use_pass_diffuse_direct)'."""
    try:
        name = bpy.types.ViewLayer.bl_rna.properties[flag].name
    except KeyError:
        name = flag
    return f"{name} ({flag})"
