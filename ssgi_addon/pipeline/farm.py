"""SSGI frames on a render farm, rendered by Blender itself (no cli.py): what ``farm_render.py``, shipped at the
extension's top level, runs in a worker.

    blender -b shot.blend -s 1 -e 24 -P <extension folder>/farm_render.py                (the frames -s/-e give)
    blender -b shot.blend -P <extension folder>/farm_render.py -- --frames 1-24          (or after --)

A worker renders its frames through the SSGI path (pipeline/render.py ``RenderSession``) with the scene's own
settings (its SSGI node's model, working resolution and temporal setting) and writes them where the scene's output
path says (Blender's ``-o`` sets it), as Blender names its frames. It exits 0 when every frame is written, 2 with one
line on stderr for a scene it cannot render (no SSGI node, no camera, a missing model ...), 1 on any other failure.

Frames split among workers equal one machine's run, bit for bit, with the temporal mode on: a worker renders the
frames before its range that its first frames blend with (they are not written), and blends nothing before the
shot's first frame. Blender's ``-s`` overwrites the scene's frame start, so the shot's own first frame is the one the
file was saved with: the extension stores it at each save (``SHOT_START``, ``on_save_pre``) and when setting up. The
temporal setting ``auto`` counts as on: a farm renders an animation, whatever the size of a worker's range.
"""
from __future__ import annotations

import argparse
import sys
import traceback

import bpy

from ...model import cliargs
from ...model.errors import UserError

from ..blender.node import SHOT_START  # scene.frame_start when the file was last saved or set up


def log(msg: str) -> None:
    print(f"SSGI farm: {msg}", file=sys.stderr, flush=True)


@bpy.app.handlers.persistent
def on_save_pre(*_args) -> None:
    """Before a save: each scene with an SSGI node keeps its frame start (``SHOT_START``) for farm workers."""
    from ..blender import node as ssgi_node
    for scene in bpy.data.scenes:
        if ssgi_node.ssgi_nodes(scene.compositing_node_group):
            scene[SHOT_START] = int(scene.frame_start)


def worker_frames(scene, argv: list[str]) -> list[int]:
    """The frames a worker renders: ``--frames`` after ``--`` on Blender's command line, else the scene's range
    (which Blender's -s and -e set), by its frame step."""
    rest = argv[argv.index("--") + 1:] if "--" in argv else []
    p = argparse.ArgumentParser(prog="farm_render.py", add_help=False)
    p.add_argument("--frames", type=cliargs.parse_frames, default=None)
    try:
        a, unknown = p.parse_known_args(rest)
    except SystemExit:
        raise UserError(f"--frames {' '.join(rest)}: frames are A-B, N or a list such as 1-3,7") from None
    if unknown:
        raise UserError(f"unknown argument(s) after --: {' '.join(unknown)} (farm_render.py takes --frames A-B)")
    if a.frames:
        return list(a.frames)
    if scene.frame_end < scene.frame_start:
        raise UserError(f"frame range {scene.frame_start}-{scene.frame_end} runs backwards")
    return list(range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step)))


def shot_start(scene, frames: list[int]) -> int:
    """The shot's first frame: the one the file was saved with, else the scene's (never after the first frame
    rendered)."""
    return min(int(scene.get(SHOT_START, scene.frame_start)), scene.frame_start, min(frames))


def render_worker(scene=None, argv: list[str] | None = None) -> dict:
    """Render a worker's frames (module doc); the RenderSession summary."""
    from . import render, render_temporal
    from ..blender import node as ssgi_node
    scene = scene or bpy.context.scene
    argv = sys.argv if argv is None else argv
    frames = worker_frames(scene, argv)
    setting = next((str(n.get(render_temporal.NODE_PROP, "")) for n in ssgi_node.ssgi_nodes(scene.compositing_node_group)
                    if n.get(render_temporal.NODE_PROP, "")), "auto")
    temporal = "off" if setting == "off" else "on"
    start = shot_start(scene, frames)
    log(f"{bpy.data.filepath or 'unsaved file'} scene {scene.name!r}: frames {frames[0]}-{frames[-1]} "
        f"({len(frames)}), temporal {temporal}, shot from frame {start}")
    session = render.RenderSession(scene, frames, temporal=temporal, shot_start=start)
    return session.run()


def main(argv: list[str] | None = None) -> int:
    """The worker's exit status (module doc)."""
    try:
        summary = render_worker(argv=argv)
    except UserError as e:
        log(f"error: {e}")
        return 2
    except Exception as e:  # noqa: BLE001 (a farm needs the status; the traceback says where)
        traceback.print_exc()
        log(f"error: {type(e).__name__}: {e}")
        return 1
    if summary.get("cancelled") or len(summary.get("files", [])) != len(summary.get("frames", [])):
        log("error: not every frame was written")
        return 1
    log(f"wrote {len(summary['files'])} frame(s), last {summary['files'][-1]}")
    return 0
