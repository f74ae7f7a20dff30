"""Operators of the SSGI node: add the node, Set up SSGI, Export ONNX, Render SSGI Image/Animation
(``bpy.ops.ssgi.render``).

``bpy.ops.ssgi.render(animation=False)`` runs the whole render synchronously (scripts, ``blender -b``);
invoked from the UI it renders one frame per timer tick (the main-thread job ``ui_jobs.render``, ops.JobSteps),
shows progress, and Esc or the Cancel button (``ssgi.cancel_job``, job "render") stops between frames,
keeping the frames already written.
"""
from __future__ import annotations

import bpy

from ..model import shipped
from ..model.errors import UserError
from ..ssgi_addon.blender import node as ssgi_node
from ..ssgi_addon.blender.predictor import pass_label
from ..ssgi_addon.pipeline import farm, render as ssgi_render
from ..ssgi_addon.runtime import ui_jobs
from . import JobSteps


def _compositor_tree(context):
    space = context.space_data
    tree = getattr(space, "edit_tree", None) if space is not None and space.type == "NODE_EDITOR" else None
    if tree is not None and tree.bl_idname == "CompositorNodeTree":
        return tree
    return None


class SSGI_OT_add_node(bpy.types.Operator):
    """Add the SSGI node: the predicted global illumination of the frame rendered with Render SSGI"""
    bl_idname = "ssgi.add_node"
    bl_label = "SSGI"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _compositor_tree(context) is not None

    def execute(self, context):
        tree = _compositor_tree(context)
        for n in tree.nodes:
            n.select = False
        loc = getattr(context.space_data, "cursor_location", (0.0, 0.0))
        node = ssgi_node.new_node(tree, tuple(loc))
        node.select = True
        tree.nodes.active = node
        return {"FINISHED"}


class SSGI_OT_setup(bpy.types.Operator):
    """Enable the passes the SSGI model needs and wire Render Layers -> SSGI -> output, keeping your nodes"""
    bl_idname = "ssgi.setup"
    bl_label = "Set up SSGI"
    bl_options = {"REGISTER", "UNDO"}

    model: bpy.props.StringProperty(name="Model", subtype="FILE_PATH", default="",
                                    description="Model checkpoint; empty uses the node's, the scene's or the shipped one")
    compiled: bpy.props.BoolProperty(name="Compiled", default=False,
                                     description="The model (a boxmlp checkpoint) as Blender's own compositor nodes: "
                                                 "plain F12 and render farms show SSGI without the extension")

    def execute(self, context):
        from ..ssgi_addon.pipeline.setup import setup
        try:
            info = setup(context.scene, self.model or None, self.compiled)
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if self.compiled:
            self.report({"INFO"}, f"SSGI compiled into {info['nodes']} nodes of group {info['group']!r} in "
                                  f"{info['tree']!r}; a plain render shows it")
            return {"FINISHED"}
        extra = f"; enabled {', '.join(pass_label(f) for f in info['enabled_passes'])}" if info["enabled_passes"] else ""
        self.report({"INFO"}, f"SSGI set up in {info['tree']!r}{extra}")
        return {"FINISHED"}


class SSGI_OT_export_onnx(bpy.types.Operator):
    """Export the model as ONNX beside it (M.onnx), which the SSGI node runs in the bundled onnxruntime,
    without PyTorch (the export itself needs PyTorch and the onnx package)"""
    bl_idname = "ssgi.export_onnx"
    bl_label = "Export ONNX"

    model: bpy.props.StringProperty(name="Model", subtype="FILE_PATH", default="",
                                    description="Model checkpoint; empty uses the node's, the scene's or the shipped one")

    def execute(self, context):
        from ..ssgi_addon.pipeline import learn
        try:
            path = ssgi_node.resolve_model(context.scene, self.model or None)
            res = learn.export(learn.ExportConfig(model=str(path), command=f"bpy.ops.ssgi.export_onnx(model={str(path)!r})"))
        except (UserError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        from ..ssgi_addon.blender.predictor import forget_models
        forget_models()
        self.report({"INFO"}, f"wrote {res['out']} (onnxruntime vs torch: {res['parity']['max_rel']:.1e} relative)")
        return {"FINISHED"}


class SSGI_OT_render(JobSteps, bpy.types.Operator):
    """Render with SSGI: EEVEE passes -> predicted GI -> your compositor -> the output path"""
    bl_idname = "ssgi.render"
    bl_label = "Render SSGI"

    animation: bpy.props.BoolProperty(name="Animation", default=False,
                                      description="Render the scene's frame range (else the current frame)")
    write_still: bpy.props.BoolProperty(name="Write", default=True,
                                        description="Write the frame(s) where the scene's output settings say")
    frame_start: bpy.props.IntProperty(name="Start", default=-1, description="First frame (-1: the scene's)")
    frame_end: bpy.props.IntProperty(name="End", default=-1, description="Last frame (-1: the scene's)")
    model: bpy.props.StringProperty(name="Model", subtype="FILE_PATH", default="",
                                    description="Model checkpoint overriding the node's setting")
    filepath: bpy.props.StringProperty(name="Output", subtype="FILE_PATH", default="",
                                       description="Output path overriding the scene's (# for frame numbers)")
    samples: bpy.props.IntProperty(name="Samples", default=0, min=0,
                                   description="EEVEE samples for the passes (0: the scene's)")

    def _frames(self, scene):
        if not self.animation and self.frame_start < 0:
            return [scene.frame_current]
        a = self.frame_start if self.frame_start >= 0 else scene.frame_start
        b = self.frame_end if self.frame_end >= 0 else (scene.frame_end if self.animation else a)
        if b < a:
            raise UserError(f"frame range {a}-{b} runs backwards")
        return list(range(a, b + 1, max(1, scene.frame_step)))

    def make_job(self, context):
        scene = context.scene
        return ui_jobs.render(scene, self._frames(scene), model=self.model or None, out=self.filepath or None,
                              write=self.write_still, samples=self.samples or None)

    def summary_text(self, summary: dict) -> str:
        n = len(summary["frames"])
        what = "cancelled after" if summary["cancelled"] else "rendered"
        files = summary["files"]
        warn = summary.get("warnings") or []
        return (f"SSGI {what} {n} frame(s)" + (f"; last: {files[-1]}" if files else "")
                + (f"; {len(warn)} warning(s): " + " | ".join(warn) if warn else ""))

    def job_finished(self, context, job):
        if job.result and not job.result["cancelled"]:
            try:
                bpy.ops.render.view_show("INVOKE_DEFAULT")
            except Exception:  # no window to show it in
                pass


def draw_add_menu(self, context):
    if _compositor_tree(context) is None:
        return
    self.layout.separator()
    self.layout.operator(SSGI_OT_add_node.bl_idname, text="SSGI", icon="SHADING_RENDERED")


def draw_render_menu(self, context):
    """At the top of the Render menu: the SSGI renders (F12 and Ctrl+F12 call them in a set-up scene) and, in a
    set-up scene, a line saying that the menu's own Render Image / Animation below show the placeholder (Python
    cannot route them), before any frame is rendered."""
    layout = self.layout
    layout.operator(SSGI_OT_render.bl_idname, text="Render SSGI Image", icon="RENDER_STILL").animation = False
    layout.operator(SSGI_OT_render.bl_idname, text="Render SSGI Animation", icon="RENDER_ANIMATION").animation = True
    if ssgi_node.is_set_up(context.scene):
        layout.label(text="SSGI: F12 renders SSGI here; Render Image below shows a placeholder", icon="INFO")
    layout.separator()


class SSGI_OT_render_key(bpy.types.Operator):
    """F12 and Ctrl+F12 with the extension enabled: in a scene set up for SSGI (an SSGI node in its compositor, the
    compositor on) the SSGI frame, as Render SSGI Image / Animation make it (a still is shown, not written, as F12's
    is); in any other scene exactly Blender's own render.render."""
    bl_idname = "ssgi.render_key"
    bl_label = "Render"
    bl_description = ("Render the current frame or the animation: with SSGI in a scene set up for it, else as "
                      "Blender renders")
    bl_options = {"REGISTER"}

    animation: bpy.props.BoolProperty(name="Animation", default=False,
                                      description="Render the scene's frame range (else the current frame)")

    def _route(self, context, how: str):
        if ssgi_node.is_set_up(context.scene):
            return bpy.ops.ssgi.render(how, animation=self.animation, write_still=self.animation)
        return bpy.ops.render.render(how, animation=self.animation, use_viewport=True)

    def invoke(self, context, event):
        return self._route(context, "INVOKE_DEFAULT")

    def execute(self, context):
        return self._route(context, "EXEC_DEFAULT")


CLASSES = (SSGI_OT_add_node, SSGI_OT_setup, SSGI_OT_export_onnx, SSGI_OT_render, SSGI_OT_render_key)
_KEYMAP_ITEMS: list = []  # (keymap, item) the extension added to Blender's add-on key configuration
# (menu, draw function, prepend): the render entries go first in the Render menu
_MENUS = (("NODE_MT_compositor_node_add_all", draw_add_menu, False), ("TOPBAR_MT_render", draw_render_menu, True))


def register_extra():
    bpy.types.CompositorNodeGroup.ssgi_model = bpy.props.StringProperty(
        name="Model file", subtype="FILE_PATH", default="",
        description="This node's own model file (.pt or .onnx); empty uses the scene's model")
    # the menu over ssgi_model: the scene's model, a shipped one by name, or a custom file (ssgi_model_custom)
    model_menu = [k for k, _, _ in shipped.menu_items(inherit=True)]

    def set_model(self, i):
        self["ssgi_model"], self["ssgi_model_custom"] = shipped.setting_for(model_menu[i], self.get("ssgi_model", ""),
                                                                            inherit=True)

    bpy.types.CompositorNodeGroup.ssgi_model_choice = bpy.props.EnumProperty(
        name="Model", items=shipped.menu_items(inherit=True),
        get=lambda self: model_menu.index(shipped.menu_choice(str(self.get("ssgi_model", "") or ""),
                                                         bool(self.get("ssgi_model_custom", False)), inherit=True)),
        set=set_model, description="The model this node predicts with: the scene's, a shipped one, or a file")
    bpy.types.CompositorNodeGroup.ssgi_working_res = bpy.props.StringProperty(
        name="Working Resolution", default="",
        description="Resolution the network predicts at, upsampled with the full-resolution G-buffer: auto (from "
                    "960 px wide 1/4 linear for a one-render model, else a working image 480 px wide; below, "
                    "full), full, 2x/4x/8x (1/N per axis) or a size such as 480x270")
    # an enum drawn as a menu, stored as the plain string ID property the render path reads (render_temporal.py)
    modes = ("auto", "on", "off")
    bpy.types.CompositorNodeGroup.ssgi_temporal = bpy.props.EnumProperty(
        name="Temporal", default="auto",
        items=[("auto", "Auto", "On when rendering more than one frame (an animation)"),
               ("on", "On", "Blend each frame with the motion-reprojected predictions of the frames before it"),
               ("off", "Off", "Every frame on its own")],
        get=lambda self: modes.index(str(self.get("ssgi_temporal", "auto") or "auto"))
        if str(self.get("ssgi_temporal", "auto") or "auto") in modes else 0,
        set=lambda self, i: self.__setitem__("ssgi_temporal", modes[i]),
        description="Blend each frame with the motion-reprojected predictions of the frames before it "
                    "where the surface is the same (less flicker)")
    for menu, fn, first in _MENUS:
        m = getattr(bpy.types, menu, None)
        if m is not None:
            (m.prepend if first else m.append)(fn)
    if ssgi_render.on_render_pre not in bpy.app.handlers.render_pre:
        bpy.app.handlers.render_pre.append(ssgi_render.on_render_pre)
    if farm.on_save_pre not in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.append(farm.on_save_pre)
    # F12 and Ctrl+F12 (the "Screen" keymap's render keys): Blender checks the add-on key configuration first
    kc = bpy.context.window_manager.keyconfigs.addon if bpy.context.window_manager else None
    if kc is not None:
        km = kc.keymaps.new(name="Screen", space_type="EMPTY")
        for ctrl in (False, True):
            kmi = km.keymap_items.new(SSGI_OT_render_key.bl_idname, "F12", "PRESS", ctrl=ctrl)
            kmi.properties.animation = ctrl
            _KEYMAP_ITEMS.append((km, kmi))


def unregister_extra():
    if ssgi_render.on_render_pre in bpy.app.handlers.render_pre:
        bpy.app.handlers.render_pre.remove(ssgi_render.on_render_pre)
    if farm.on_save_pre in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.remove(farm.on_save_pre)
    for km, kmi in _KEYMAP_ITEMS:
        try:
            km.keymap_items.remove(kmi)
        except (ReferenceError, RuntimeError):  # the key configuration went first (Blender quitting)
            pass
    _KEYMAP_ITEMS.clear()
    for menu, fn, _first in _MENUS:
        m = getattr(bpy.types, menu, None)
        if m is not None:
            m.remove(fn)
    for prop in ("ssgi_model", "ssgi_model_choice", "ssgi_working_res", "ssgi_temporal"):
        if hasattr(bpy.types.CompositorNodeGroup, prop):
            delattr(bpy.types.CompositorNodeGroup, prop)
