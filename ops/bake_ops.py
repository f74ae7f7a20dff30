"""Operators: Randomize Room and Bake Dataset. Thin: ssgi_addon's room and bake do the work, the same code as
``cli.py randomize`` and ``cli.py bake``.

Bake Dataset touches bpy (it renders), so it cannot run in a worker thread: it runs the main-thread job
``ui_jobs.bake`` (one sample per step, ops.JobSteps), with progress in the Dataset panel and the status bar;
Esc or Cancel (``ssgi.cancel_job``, job "bake") stops before the next sample, leaving a valid dataset that the
same settings resume. Run from a script (``execute``) it bakes to the end.
"""
from __future__ import annotations

import bpy

from ..ssgi_addon import props
from ..ssgi_addon.blender import room
from ..ssgi_addon.runtime import jobs, ui_jobs
from . import JobSteps


class SSGI_OT_randomize_room(bpy.types.Operator):
    """Build a random room (box, primitives, lights, camera) from a seed, diffuse or artist-style. In a room scene this rebuilds
    it; elsewhere it makes a new scene, so your scenes are left alone"""
    bl_idname = "ssgi.randomize_room"
    bl_label = "Randomize Room"
    bl_options = {"REGISTER", "UNDO"}

    seed: bpy.props.IntProperty(name="Seed", default=0, min=0, description="Room seed (same seed, same room)")
    mode: bpy.props.EnumProperty(name="Kind", default="diffuse", items=props.ROOM_MODES)

    def invoke(self, context, event):
        s = getattr(context.scene, "ssgi", None)
        if s is not None:
            self.seed = s.room_seed
            self.mode = s.room_mode
        return self.execute(context)

    def execute(self, context):
        scene = context.scene
        if scene is None or "ssgi_room_seed" not in scene:
            scene = None  # a new scene: never fill the user's own scene with a room
        scene = room.build_room(self.seed, scene, self.mode)
        scene.name = f"SSGI Room {self.seed}"
        if context.window is not None:
            context.window.scene = scene
        if getattr(scene, "ssgi", None) is not None:
            scene.ssgi.room_seed = self.seed
            scene.ssgi.room_mode = self.mode
        self.report({"INFO"}, f"Room {self.seed} ({self.mode}): {len(scene.objects)} objects in scene {scene.name!r}")
        return {"FINISHED"}


class SSGI_OT_bake_dataset(JobSteps, bpy.types.Operator):
    """Bake random rooms into the dataset folder: EEVEE direct-light passes and a Cycles reference per room.
    Blender is busy while each sample renders; Esc or Cancel stops after it, and baking again resumes"""
    bl_idname = "ssgi.bake_dataset"
    bl_label = "Bake Dataset"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and not jobs.running(ui_jobs.BAKE)

    def make_job(self, context):
        return ui_jobs.bake(context.scene)

    def summary_text(self, summary: dict) -> str:
        what = "cancelled after" if summary["status"] == "cancelled" else "baked"
        return (f"SSGI bake {what} {summary['baked']} sample(s); {summary['skipped']} were already there; "
                f"{summary['total']} in all -> {summary['out']}")


CLASSES = (SSGI_OT_randomize_room, SSGI_OT_bake_dataset)
