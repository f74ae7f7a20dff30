"""Add-on preferences: the dependency installer, the thread count, and the runtime and device of prediction."""
from __future__ import annotations

import bpy

from .runtime import deps, jobs


def prefs(context=None):
    from . import root_package
    context = context or bpy.context
    addon = context.preferences.addons.get(root_package())
    return addon.preferences if addon else None


def torch_threads(context=None) -> int:
    """Threads torch uses in Blender. One thread was several times faster than two in a process that also
    renders on this 2-core machine (shared/blender5-notes.md), hence the default."""
    p = prefs(context)
    return int(p.torch_threads) if p else 1


class SSGI_AddonPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__.rsplit(".", 1)[0]

    torch_threads: bpy.props.IntProperty(
        name="Threads", default=1, min=1, max=64,
        description="CPU threads for training and prediction (torch or onnxruntime) inside Blender (1 keeps the "
                    "UI and renders responsive)")

    runtime: bpy.props.EnumProperty(
        name="Runtime", default="AUTO",
        items=[("AUTO", "Auto", "onnxruntime (bundled) when the model has an ONNX export beside it, else PyTorch"),
               ("ONNX", "onnxruntime", "The bundled onnxruntime: needs the model's .onnx export beside it"),
               ("TORCH", "PyTorch", "PyTorch (installed with 'Install Python dependencies'): runs any .pt")],
        description="What runs the SSGI node's network")
    device: bpy.props.EnumProperty(
        name="Device", default="AUTO",
        items=[("AUTO", "Auto", "A GPU the runtime can use (CUDA, MPS; DirectML or CoreML in onnxruntime), else the CPU"),
               ("CPU", "CPU", "The CPU"), ("CUDA", "CUDA", "An NVIDIA GPU (CPU when there is none)"),
               ("MPS", "MPS", "Apple's GPU: Metal in PyTorch, CoreML in onnxruntime (CPU when there is none)")],
        description="Where prediction runs; a GPU that is absent falls back to the CPU, never an error")

    pip_requirement: bpy.props.StringProperty(
        name="Package", default=deps.TORCH_REQUIREMENT,
        description="What 'Install Python dependencies' asks pip for")
    pip_extra_args: bpy.props.StringProperty(
        name="Extra pip arguments", default="",
        description="Added to the pip command, e.g. '--index-url https://download.pytorch.org/whl/cpu' for the "
                    "smaller CPU-only torch build (PyPI's Linux torch is the CUDA build, about 3.5 GB)")

    def draw(self, context):
        layout = self.layout
        ok, info = deps.torch_status()
        box = layout.box()
        box.label(text=f"PyTorch: {info}" if ok else "PyTorch: not installed", icon="CHECKMARK" if ok else "ERROR")
        d = deps.deps_dir()
        box.label(text=f"Install folder: {d}" if d else "Install folder: (not an installed extension)")
        job = jobs.get("deps")
        if job and not job.done:
            box.label(text=f"Installing... {job.state.get('message', '')[:80]}")
            box.operator("ssgi.cancel_job", text="Cancel").job = "deps"
        else:
            if job and job.error:
                box.label(text=f"Install failed: {job.state.get('message', '')[:160]}", icon="ERROR")
            elif job and job.result is not None:
                box.label(text=job.state.get("message", "")[:100], icon="CHECKMARK")
            box.prop(self, "pip_requirement")
            box.prop(self, "pip_extra_args")
            row = box.row()
            row.enabled = bool(bpy.app.online_access)
            row.operator("ssgi.install_deps", icon="IMPORT")
            if not bpy.app.online_access:
                box.label(text="Allow online access in Preferences > System to install", icon="INFO")
        layout.prop(self, "torch_threads")
        row = layout.row()
        row.prop(self, "runtime")
        row.prop(self, "device")
        ort_ok, ort_info = deps.onnxruntime_status()
        layout.label(text=f"onnxruntime: {ort_info}" if ort_ok else "onnxruntime: not importable",
                     icon="CHECKMARK" if ort_ok else "ERROR")


CLASSES = (SSGI_AddonPreferences,)
