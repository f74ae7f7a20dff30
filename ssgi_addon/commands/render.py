"""`cli.py render`: render a .blend's frames through the SSGI node, headless.

    cli.py render --blend shot.blend --out out/shot_#### --frames 1-48 [--model m.pt] [--json]

The .blend must hold an SSGI node in its compositor (Set up SSGI, or ``--setup`` to do it here). Frames are
written in the scene's output format; without ``--out`` where the scene's output path says. The .blend itself
is never written.
"""
from __future__ import annotations

import sys
from pathlib import Path

from ...model import cliargs
from ...model.dataset.exrio import stdout_to_stderr


def run(args) -> dict:
    with stdout_to_stderr():
        return _run(args)


def _run(args) -> dict:
    from ..pipeline import render as ssgi_render
    from ..blender.blendfile import open_blend, pick_scene

    blend = Path(args.blend).expanduser()
    open_blend(args.blend)
    scene = pick_scene(blend, args.scene)
    if args.setup:
        from ..blender.compositor import setup_scene
        setup_scene(scene, args.model)
    frames = list(args.frames) if args.frames else [scene.frame_current]
    session = ssgi_render.RenderSession(scene, frames, model=args.model, out=args.out, samples=args.samples,
                                        save_passes=args.save_passes)
    print(f"SSGI render: {blend.name} scene {scene.name!r}, {len(frames)} frame(s), model {session.model_path}",
          file=sys.stderr)
    try:
        from tqdm import tqdm
        bar = tqdm(total=len(frames), unit="frame", file=sys.stderr, disable=len(frames) < 2)
    except ImportError:
        bar = None
    try:
        for _ in session.iter_frames():
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return session.summary()


def register_cli(sub) -> None:
    p = sub.add_parser("render", help="render a .blend's frames through the SSGI compositor node",
                       description="Render frames of a .blend with SSGI: EEVEE passes -> predicted global "
                                   "illumination -> the file's compositor -> image files in the scene's format.")
    p.add_argument("--blend", required=True, help="the .blend file (not modified)")
    p.add_argument("--out", default=None,
                   help="output path; '#' marks the frame number (as Blender's -o); default: the scene's output path")
    p.add_argument("--frames", type=cliargs.parse_frames, default=None,
                   help="frames to render: A-B, N or a list 1-3,7 (default: the scene's current frame)")
    p.add_argument("--model", default=None, help="model checkpoint (default: the SSGI node's, or the shipped model)")
    p.add_argument("--scene", default=None, help="scene name (default: the file's active scene)")
    p.add_argument("--samples", type=cliargs.positive_int, default=None,
                   help="EEVEE samples for the passes (default: the scene's render samples)")
    p.add_argument("--setup", action="store_true",
                   help="run Set up SSGI first (enable passes, insert the node) if the file lacks it")
    p.add_argument("--save-passes", default=None, metavar="DIR",
                   help="also write each frame's G-buffer (the model's input) as DIR/NNNNNN.exr (32-bit)")
    p.set_defaults(func=run)
