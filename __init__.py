"""SSGI Blender extension: learned global illumination for EEVEE renders.

register()/unregister() gather the classes of the UI modules listed in ``_modules`` (explicit imports, in
registration order: property groups before what uses them). The learning half lives in model/ and never
imports bpy; the modules are imported inside ``_modules`` so that loading the package (cli.py, tests, a
training child process) does not import bpy.
"""
from __future__ import annotations


def _modules() -> tuple:
    from .ops import bake_ops, deps_ops, fit_ops, job_ops, node_ops, report_ops, train_ops
    from .panels import bake_panel, fit_panel, main_panel, node_panel, report_panel, status_bar, train_panel
    from .ssgi_addon import preferences, props
    return (props, preferences, job_ops, deps_ops, main_panel, status_bar, bake_ops, bake_panel, node_ops,
            node_panel, train_ops, train_panel, report_ops, report_panel, fit_ops, fit_panel)


def _classes() -> list:
    out = []
    for m in _modules():
        out.extend(getattr(m, "CLASSES", ()))
    return out


def register():
    import bpy

    from .ssgi_addon.runtime import deps
    deps.add_to_path()
    for cls in _classes():
        bpy.utils.register_class(cls)
    for m in _modules():
        if hasattr(m, "register_extra"):
            m.register_extra()


def unregister():
    import bpy

    from .ssgi_addon.runtime import jobs
    jobs.shutdown()
    for m in reversed(_modules()):
        if hasattr(m, "unregister_extra"):
            m.unregister_extra()
    for cls in reversed(_classes()):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
