"""Scenes that move, built by script (deterministic) and saved as .blend files for
``cli.py fit --frames``, ``cli.py render`` and the temporal benchmark.

    .venv/bin/python -m scenes.shots --out DIR [--size 240x135] [--frames 48] [--names ripple room living_room]
    .venv/bin/python -m scenes.shots --look out/shot_scenes [--size 160x90]   # EEVEE strips of 3 frames

Scenes (``NAMES``), each animated over frames 1..N (N = ``--frames``, 48 by default):

- ``ripple``: after Neuron Render's public test scene (MildyNora/neuron-render, scenes/make_scenes.py, whose
  docstring reads "a 40-frame animation in which meshes change shape: a sphere with a wave travelling over
  it, a cylinder that bends over, a cube that tumbles across, a camera that drifts"). Taken from it: the
  cast (red sphere of radius 1 with a Wave modifier, green subdivided cylinder bent 0 -> 80 degrees by a
  Simple Deform, blue 1.2 m cube moving and turning, a grey floor, a sun, a blue-grey sky, a camera drifting
  sideways and up) and its layout; our own: the materials (diffuse-ish Principled), the light strength, the
  frame count as a parameter, EEVEE/Cycles settings of scenes/artist.py.
- ``room``: SSGI's own shot. A closed 4 x 3 x 2.5 m room with a warm-white and a red wall, lit by one area
  lamp under the ceiling and a small point lamp (so most of the walls' light is bounce light); a camera that
  dollies in and pans; a yellow ball that rolls across the floor (a moving object); a cloth-like plane over
  a box that waves (Wave modifier) and a column that twists (Simple Deform, deforming meshes).
- ``living_room``: scenes/artist.py's living room, the camera moving along the room (a slow
  truck right and push in, looking at the armchair and the lamp) over the frame range.
- ``cornell_emissive``, ``studio``: scenes/artist.py's scenes of the same names,
  the camera moving (the Cornell box: a push in and to the right, tilting down to the ball; the studio: an
  orbit to the left, rising) over the frame range; nothing else moves, as in ``living_room``.

API: ``build(name, size, frames)`` resets Blender to an empty file, builds the shot, returns the scene;
``save(scene, path)`` (artist_scenes.save) writes atomically; ``build_<name>(scene, frames)`` fills an empty
scene.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from scenes import artist as art  # noqa: E402
import bpy  # noqa: E402

import scenes  # noqa: E402  (the checkout as package ssgi)
import bmesh  # noqa: E402
from mathutils import Vector  # noqa: E402

NAMES = ("ripple", "room", "living_room", "cornell_emissive", "studio")
DEFAULT_SIZE = (240, 135)
DEFAULT_FRAMES = 48


def _keys(obj, path, frames_values, owner=None):
    """Keyframe ``path`` of ``owner`` (default ``obj``) at each (frame, value); linear interpolation (a shot's
    motion without ease at the ends would be the artist's; linear makes every frame move)."""
    owner = owner or obj
    for f, v in frames_values:
        setattr(owner, path, v)
        owner.keyframe_insert(path, frame=f)
    ad = obj.animation_data
    if ad and ad.action:
        for fc in _fcurves(ad.action):
            for k in fc.keyframe_points:
                k.interpolation = "LINEAR"


def _fcurves(action):
    """The F-curves of ``action`` (Blender 5 keeps them in layers/strips/channelbags)."""
    out = []
    for layer in getattr(action, "layers", ()):
        for strip in layer.strips:
            for cb in getattr(strip, "channelbags", ()):
                out.extend(cb.fcurves)
    return out


def _aim_keys(cam, poses):
    """Camera keys: ``poses`` = [(frame, location, target)], rotation aimed at the target at each key."""
    for f, loc, target in poses:
        cam.location = loc
        art.aim(cam, target)
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
    for fc in _fcurves(cam.animation_data.action):
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"


def _subdivided_cylinder(scene, name, center, radius, height, mat, cuts=12, segments=24):
    """A cylinder with ``cuts`` rings along its height (a Simple Deform needs vertices to bend)."""
    bm = bmesh.new()
    bmesh.ops.create_cone(bm, cap_ends=True, segments=segments, radius1=radius, radius2=radius, depth=height)
    side = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > 1e-6]
    bmesh.ops.subdivide_edges(bm, edges=side, cuts=cuts, use_grid_fill=True)
    return art._object(scene, name, bm, mat, center, smooth=True)


def _grid(scene, name, center, size, mat, cuts=24):
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=cuts, y_segments=cuts, size=0.5)
    bmesh.ops.scale(bm, vec=(size[0], size[1], 1.0), verts=bm.verts)
    return art._object(scene, name, bm, mat, center, smooth=True)


def build_ripple(scene, frames: int = DEFAULT_FRAMES) -> None:
    n = int(frames)
    art.plane(scene, "floor", (0, 0, 0), (12, 12), art.principled("ground", (0.6, 0.6, 0.6), roughness=0.6))
    s = art.sphere(scene, "ripple", (-1.6, 0, 1.1), 1.0, art.principled("red", (0.7, 0.1, 0.1), roughness=0.4))
    wave = s.modifiers.new("wave", "WAVE")  # travels with the frame number on its own
    wave.height, wave.width, wave.speed, wave.use_normal = 0.25, 0.8, 0.12 * 40 / n, True
    cube = art.box(scene, "mover", (1.8, 0.5, 0.6), (1.2, 1.2, 1.2), art.principled("blue", (0.1, 0.2, 0.7), roughness=0.5))
    _keys(cube, "location", [(1, Vector((1.8, 0.5, 0.6))), (n, Vector((1.2, -1.0, 1.1)))])
    _keys(cube, "rotation_euler", [(1, Vector((0, 0, 0))), (n, Vector((0.3, 0.2, 1.2)))])
    cyl = _subdivided_cylinder(scene, "bender", (0.3, 1.6, 1.2), 0.25, 2.4,
                               art.principled("green", (0.1, 0.6, 0.2), roughness=0.6))
    bend = cyl.modifiers.new("bend", "SIMPLE_DEFORM")
    bend.deform_method, bend.deform_axis = "BEND", "X"
    for f, a in ((1, 0.0), (n, math.radians(80))):
        bend.angle = a
        bend.keyframe_insert("angle", frame=f)
    art.light(scene, "sun", "SUN", (3.0, -3.0, 6.0), 3.0, target=(0.4, 0.2, 0.0), angle_deg=2.0)
    art.world_colour(scene, (0.3, 0.35, 0.45), 1.0)
    cam = art.camera(scene, (0, -8, 3.2), (0, 0, 0.6), lens=40.0)
    _aim_keys(cam, [(1, (0, -8, 3.2), (0, 0, 0.6)), (n, (1.5, -7.5, 3.6), (0.3, 0, 0.6))])


def build_room(scene, frames: int = DEFAULT_FRAMES) -> None:
    n = int(frames)
    w, d, h = 4.0, 3.0, 2.5
    warm = art.diffuse("warm_white", (0.78, 0.74, 0.66))
    art._room_shell(scene, (art.diffuse("floor_oak", (0.45, 0.32, 0.2)), art.diffuse("ceiling", (0.85, 0.85, 0.85)),
                            warm), w, d, h, skip=("wall_left",))
    art.box(scene, "wall_left", (-w / 2 - 0.075, 0, h / 2), (0.15, d, h), art.diffuse("red_wall", (0.7, 0.12, 0.08)))
    art.box(scene, "table", (0.6, 0.5, 0.35), (1.0, 0.7, 0.7), art.diffuse("table", (0.5, 0.6, 0.7)))
    cloth = _grid(scene, "cloth", (0.6, 0.5, 0.72), (1.2, 0.9), art.diffuse("cloth", (0.85, 0.85, 0.8)))
    wv = cloth.modifiers.new("wave", "WAVE")
    wv.height, wv.width, wv.speed, wv.narrowness = 0.08, 0.4, 0.6 * 48 / n, 1.5
    col = _subdivided_cylinder(scene, "column", (-1.2, 0.9, 0.8), 0.18, 1.6, art.diffuse("column", (0.3, 0.55, 0.3)),
                               segments=6)
    tw = col.modifiers.new("twist", "SIMPLE_DEFORM")
    tw.deform_method, tw.deform_axis = "TWIST", "Z"
    for f, a in ((1, 0.0), (n, math.radians(150))):
        tw.angle = a
        tw.keyframe_insert("angle", frame=f)
    ball = art.sphere(scene, "ball", (-1.2, -0.6, 0.25), 0.25, art.diffuse("yellow", (0.85, 0.7, 0.1)))
    _keys(ball, "location", [(1, Vector((-1.3, -0.7, 0.25))), (n, Vector((0.5, -0.7, 0.25)))])
    _keys(ball, "rotation_euler", [(1, Vector((0, 0, 0))), (n, Vector((0, 1.8 / 0.25, 0)))])  # rolls
    art.light(scene, "lamp", "AREA", (0.3, 0.3, h - 0.05), 120.0, target=(0.3, 0.3, 0.0), size=0.6,
              colour=(1.0, 0.92, 0.8))
    art.light(scene, "fill", "POINT", (1.5, -1.2, 1.8), 15.0, size=0.05, colour=(1.0, 0.85, 0.7))
    art.world_colour(scene, (0.0, 0.0, 0.0), 0.0)
    cam = art.camera(scene, (1.7, -1.4, 1.5), (-0.2, 0.5, 0.7), lens=20.0)
    _aim_keys(cam, [(1, (1.75, -1.4, 1.5), (-0.4, 0.6, 0.7)), (n, (0.9, -1.1, 1.3), (0.6, 0.6, 0.6))])


def build_living_room(scene, frames: int = DEFAULT_FRAMES) -> None:
    n = int(frames)
    art.build_living_room(scene)
    cam = scene.camera
    _aim_keys(cam, [(1, (1.9, -1.75, 1.45), (-0.6, 1.2, 0.9)), (n, (0.9, -1.55, 1.35), (-1.0, 1.0, 0.9))])


def build_cornell_emissive(scene, frames: int = DEFAULT_FRAMES) -> None:
    n = int(frames)
    art.build_cornell_emissive(scene)
    cam = scene.camera
    _aim_keys(cam, [(1, (0.0, -3.0, 1.0), (0.0, 0.0, 1.0)), (n, (0.45, -2.55, 1.15), (-0.1, 0.2, 0.85))])


def build_studio(scene, frames: int = DEFAULT_FRAMES) -> None:
    n = int(frames)
    art.build_studio(scene)
    cam = scene.camera
    _aim_keys(cam, [(1, (0.0, -3.6, 1.2), (0.0, 0.4, 0.5)), (n, (-0.9, -3.2, 1.4), (0.05, 0.4, 0.45))])


BUILDERS = dict(ripple=build_ripple, room=build_room, living_room=build_living_room,
                cornell_emissive=build_cornell_emissive, studio=build_studio)


def build(name: str, size=DEFAULT_SIZE, frames: int = DEFAULT_FRAMES):
    """Blender reset to an empty file, shot ``name`` built into it at ``size`` over frames 1..``frames``."""
    if name not in BUILDERS:
        raise ValueError(f"{name!r}: no such shot; shots: {', '.join(NAMES)}")
    if int(frames) < 2:
        raise ValueError(f"frames {frames}: a shot needs at least 2 frames")
    scene = scenes.empty_scene()
    scene.name = name
    BUILDERS[name](scene, int(frames))
    art.render_settings(scene, size)  # (sets frames 1..1: the shot's range follows)
    scene.frame_start, scene.frame_end = 1, int(frames)
    scene.frame_set(1)
    return scene


save = art.save


def look(names, size, frames: int, out_dir) -> list[Path]:
    """A strip of EEVEE renders (the file's own settings) of the first, middle and last frame of each shot,
    as PNG: ``out_dir/NAME_strip.png``."""
    import numpy as np

    from ssgi.model import images
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name in names:
        scene = build(name, size, frames)
        tiles = []
        for f in (1, (1 + frames) // 2, frames):
            scene.frame_set(f)
            img, _s = art.render_eevee(scene)
            tiles.append(img)
        strip = np.concatenate([np.pad(t, ((0, 0), (0, 2), (0, 0))) for t in tiles], axis=1)
        p = out_dir / f"{name}_strip.png"
        images.write_png(p, images.srgb8(strip))
        written.append(p)
        print(f"{p}: frames 1, {(1 + frames) // 2}, {frames}", file=sys.stderr)
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", metavar="DIR", help="write NAME.blend for each shot here")
    ap.add_argument("--look", metavar="DIR", help="write EEVEE strips of frames (first, middle, last) here")
    ap.add_argument("--size", default=None, help="WxH (default 240x135; --look 160x90)")
    ap.add_argument("--frames", type=int, default=DEFAULT_FRAMES, help="frames 1..N (default %(default)s)")
    ap.add_argument("--names", nargs="+", default=list(NAMES), choices=NAMES)
    a = ap.parse_args(argv)
    if not a.out and not a.look:
        ap.error("give --out DIR and/or --look DIR")
    from ssgi.model import cliargs
    if a.out:
        size = cliargs.parse_size(a.size) if a.size else DEFAULT_SIZE
        Path(a.out).mkdir(parents=True, exist_ok=True)
        for name in a.names:
            p = save(build(name, size, a.frames), Path(a.out) / f"{name}.blend")
            print(p)
    if a.look:
        look(a.names, cliargs.parse_size(a.size) if a.size else (160, 90), a.frames, a.look)
    return 0


if __name__ == "__main__":
    sys.exit(main())
