"""Operators of the SSGI node: add the node, Set up SSGI, Render SSGI Image/Animation (``bpy.ops.ssgi.render``).

``bpy.ops.ssgi.render(animation=False)`` runs the whole render synchronously (scripts, ``blender -b``);
invoked from the UI it renders one frame per timer tick, shows progress, and Esc or the Cancel button stops
between frames, keeping the frames already written.
"""
from __future__ import annotations

import bpy

from ..model.errors import UserError
from ..ssgi_addon.blender import node as ssgi_node
from ..ssgi_addon.blender.compositor import setup_scene
from ..ssgi_addon.blender.predictor import pass_label
from ..ssgi_addon.pipeline import render as ssgi_render
from . import TimerSteps, cancel_state


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

    def execute(self, context):
        try:
            info = setup_scene(context.scene, self.model or None)
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        extra = f"; enabled {', '.join(pass_label(f) for f in info['enabled_passes'])}" if info["enabled_passes"] else ""
        self.report({"INFO"}, f"SSGI set up in {info['tree']!r}{extra}")
        return {"FINISHED"}


class SSGI_OT_render(TimerSteps, bpy.types.Operator):
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

    _session = None
    _iter = None

    def _frames(self, scene):
        if not self.animation and self.frame_start < 0:
            return [scene.frame_current]
        a = self.frame_start if self.frame_start >= 0 else scene.frame_start
        b = self.frame_end if self.frame_end >= 0 else (scene.frame_end if self.animation else a)
        if b < a:
            raise UserError(f"frame range {a}-{b} runs backwards")
        return list(range(a, b + 1, max(1, scene.frame_step)))

    def _session_for(self, context):
        scene = context.scene
        return ssgi_render.RenderSession(scene, self._frames(scene), model=self.model or None,
                                         out=self.filepath or None, write=self.write_still,
                                         samples=self.samples or None)

    def execute(self, context):
        try:
            session = self._session_for(context)
            _start_state(len(session.frames))
            summary = session.run(should_cancel=lambda: ssgi_render.STATE.get("cancel", False))
        except UserError as e:
            ssgi_render.STATE.update(status="error", message=str(e))
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        _end_state(session)
        self.report({"INFO"}, _summary_text(summary))
        return {"FINISHED"}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        try:
            self._session = self._session_for(context)
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        _start_state(len(self._session.frames))
        self._iter = self._session.iter_frames(lambda: ssgi_render.STATE.get("cancel", False))
        return self.start_steps(context, len(self._session.frames))

    # TimerSteps: one frame per timer tick
    def step_work(self, context):
        n = len(self._session.results)
        try:
            info = next(self._iter)
        except StopIteration:
            return False, n
        n = len(self._session.results)
        ssgi_render.STATE.update(done=n, progress=n / max(1, len(self._session.frames)),
                                 message=f"frame {info['frame']} done")
        return True, n

    def stop_request(self):
        ssgi_render.STATE["cancel"] = True

    def steps_finished(self, context):
        _end_state(self._session)
        self.report({"INFO"}, _summary_text(self._session.summary()))
        if not self._session.cancelled:
            with _suppress():
                bpy.ops.render.view_show("INVOKE_DEFAULT")

    def steps_failed(self, context, message):
        _end_state(self._session)
        ssgi_render.STATE.update(status="error", message=message)


def _suppress():
    import contextlib
    return contextlib.suppress(Exception)


def _start_state(total: int) -> None:
    ssgi_render.STATE.update(status="running", message="", progress=0.0, done=0, total=total, cancel=False)


def _end_state(session) -> None:
    ssgi_render.STATE.update(status="cancelled" if session.cancelled else "done", progress=1.0,
                             done=len(session.results), cancel=False,
                             message=(session.results[-1].get("path", "") if session.results else ""))


def _summary_text(summary: dict) -> str:
    n = len(summary["frames"])
    what = "cancelled after" if summary["cancelled"] else "rendered"
    files = summary["files"]
    return f"SSGI {what} {n} frame(s)" + (f"; last: {files[-1]}" if files else "")


class SSGI_OT_render_cancel(bpy.types.Operator):
    """Stop the SSGI render after the current frame; frames already written are kept"""
    bl_idname = "ssgi.render_cancel"
    bl_label = "Cancel SSGI Render"

    def execute(self, context):
        return cancel_state(self, ssgi_render.STATE, "SSGI render")


def draw_add_menu(self, context):
    if _compositor_tree(context) is None:
        return
    self.layout.separator()
    self.layout.operator(SSGI_OT_add_node.bl_idname, text="SSGI", icon="SHADING_RENDERED")


def draw_render_menu(self, context):
    layout = self.layout
    layout.separator()
    layout.operator(SSGI_OT_render.bl_idname, text="Render SSGI Image", icon="RENDER_STILL").animation = False
    layout.operator(SSGI_OT_render.bl_idname, text="Render SSGI Animation", icon="RENDER_ANIMATION").animation = True


CLASSES = (SSGI_OT_add_node, SSGI_OT_setup, SSGI_OT_render, SSGI_OT_render_cancel)
_MENUS = (("NODE_MT_compositor_node_add_all", draw_add_menu), ("TOPBAR_MT_render", draw_render_menu))


def register_extra():
    bpy.types.CompositorNodeGroup.ssgi_model = bpy.props.StringProperty(
        name="Model", subtype="FILE_PATH", default="",
        description="SSGI model checkpoint (.pt); empty uses the scene's model or the shipped default")
    for menu, fn in _MENUS:
        m = getattr(bpy.types, menu, None)
        if m is not None:
            m.append(fn)
    if ssgi_render.on_render_pre not in bpy.app.handlers.render_pre:
        bpy.app.handlers.render_pre.append(ssgi_render.on_render_pre)


def unregister_extra():
    if ssgi_render.on_render_pre in bpy.app.handlers.render_pre:
        bpy.app.handlers.render_pre.remove(ssgi_render.on_render_pre)
    for menu, fn in _MENUS:
        m = getattr(bpy.types, menu, None)
        if m is not None:
            m.remove(fn)
    if hasattr(bpy.types.CompositorNodeGroup, "ssgi_model"):
        del bpy.types.CompositorNodeGroup.ssgi_model
