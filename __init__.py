"""SSGI Blender extension: learned global illumination for EEVEE renders.

register()/unregister() only gather the classes of ssgi_addon/, ops/ and panels/. The learning half lives
in model/ and never imports bpy.
"""
from __future__ import annotations

import importlib

# Modules with a CLASSES tuple, in registration order (property groups before what uses them).
_CLASS_MODULES = (
    "ssgi_addon.props",
    "ssgi_addon.preferences",
    "ops.deps_ops",
    "panels.main_panel",
    "ops.bake_ops",
    "panels.bake_panel",
    "ops.node_ops",
    "panels.node_panel",
    "ssgi_addon.training",
    "ops.train_ops",
    "panels.train_panel",
    "ops.report_ops",
    "panels.report_panel",
    "ops.fit_ops",
    "panels.fit_panel",
)


def _modules():
    return [importlib.import_module(f"{__name__}.{m}") for m in _CLASS_MODULES]


def _classes():
    out = []
    for m in _modules():
        out.extend(getattr(m, "CLASSES", ()))
    return out


def register():
    import bpy

    from .ssgi_addon import deps
    deps.add_to_path()
    for cls in _classes():
        bpy.utils.register_class(cls)
    for m in _modules():
        if hasattr(m, "register_extra"):
            m.register_extra()


def unregister():
    import bpy

    from .ssgi_addon import jobs
    jobs.shutdown()
    for m in reversed(_modules()):
        if hasattr(m, "unregister_extra"):
            m.unregister_extra()
    for cls in reversed(_classes()):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
