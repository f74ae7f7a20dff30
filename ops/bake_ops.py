"""Operators: Randomize Room, Bake Dataset and Cancel Bake. Thin: ssgi_addon.room and ssgi_addon.bake do the
work, the same code as ``cli.py randomize`` and ``cli.py bake``.

Bake Dataset touches bpy (it renders), so it cannot run in a worker thread: invoked from the UI it is a modal
operator that bakes one sample per timer tick on the main thread (``bake.BakeSession.step``), with progress in
the Dataset panel and the status bar; Esc or Cancel stops before the next sample, leaving a valid dataset that
the same settings resume. Run from a script (``execute``) it bakes to the end.
"""
from __future__ import annotations

import bpy

from ..model.errors import UserError
from ..ssgi_addon.pipeline import bake
from ..ssgi_addon.blender import room
from . import TimerSteps, cancel_state


class SSGI_OT_randomize_room(bpy.types.Operator):
    """Build a random room (box, diffuse primitives, lights, camera) from a seed. In a room scene this rebuilds
    it; elsewhere it makes a new scene, so your scenes are left alone"""
    bl_idname = "ssgi.randomize_room"
    bl_label = "Randomize Room"
    bl_options = {"REGISTER", "UNDO"}

    seed: bpy.props.IntProperty(name="Seed", default=0, min=0, description="Room seed (same seed, same room)")

    def invoke(self, context, event):
        s = getattr(context.scene, "ssgi", None)
        if s is not None:
            self.seed = s.room_seed
        return self.execute(context)

    def execute(self, context):
        scene = context.scene
        if scene is None or "ssgi_room_seed" not in scene:
            scene = None  # a new scene: never fill the user's own scene with a room
        scene = room.build_room(self.seed, scene)
        scene.name = f"SSGI Room {self.seed}"
        if context.window is not None:
            context.window.scene = scene
        if getattr(scene, "ssgi", None) is not None:
            scene.ssgi.room_seed = self.seed
        self.report({"INFO"}, f"Room {self.seed}: {len(scene.objects)} objects in scene {scene.name!r}")
        return {"FINISHED"}


class SSGI_OT_bake_dataset(TimerSteps, bpy.types.Operator):
    """Bake random rooms into the dataset folder: EEVEE direct-light passes and a Cycles reference per room.
    Blender is busy while each sample renders; Esc or Cancel stops after it, and baking again resumes"""
    bl_idname = "ssgi.bake_dataset"
    bl_label = "Bake Dataset"

    _session = None

    @classmethod
    def poll(cls, context):
        return context.scene is not None and bake.STATE.get("status") != "running"

    def execute(self, context):
        try:
            summary = bake.BakeSession.from_scene(context.scene).run()
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, _summary_text(summary))
        return {"FINISHED"}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        try:
            self._session = bake.BakeSession.from_scene(context.scene)
        except UserError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return self.start_steps(context, self._session.start["todo"])

    # TimerSteps: one sample per timer tick
    def step_work(self, context):
        return self._session.step(), bake.STATE.get("done", 0)

    def stop_request(self):
        self._session.cancel()

    def steps_finished(self, context):
        self.report({"INFO"}, _summary_text(self._session.summary))


def _summary_text(summary: dict) -> str:
    what = "cancelled after" if summary["status"] == "cancelled" else "baked"
    return (f"SSGI bake {what} {summary['baked']} sample(s); {summary['skipped']} were already there; "
            f"{summary['total']} in all -> {summary['out']}")


class SSGI_OT_bake_cancel(bpy.types.Operator):
    """Stop the bake after the current sample; every sample written so far is kept, and baking again resumes"""
    bl_idname = "ssgi.bake_cancel"
    bl_label = "Cancel Bake"

    def execute(self, context):
        return cancel_state(self, bake.STATE, "bake")


CLASSES = (SSGI_OT_randomize_room, SSGI_OT_bake_dataset, SSGI_OT_bake_cancel)


def register_extra():
    bpy.types.STATUSBAR_HT_header.append(bake.draw_status)


def unregister_extra():
    if bake.STATE.get("status") == "running":
        bake.STATE["cancel"] = True
    try:
        bpy.types.STATUSBAR_HT_header.remove(bake.draw_status)
    except ValueError:
        pass
