"""`cli.py render`: the render stage (ssgi_addon/pipeline/render.py) behind argparse.

    cli.py render --blend shot.blend --out out/shot_#### --frames 1-48 [--model m.pt] [--json]

The .blend must hold an SSGI node in its compositor (Set up SSGI, or ``--setup`` to do it here). Frames are
written in the scene's output format, or in the one a known image extension of ``--out`` names (as Blender's
``-F``: ``--out x.exr`` writes OpenEXR); without ``--out`` where the scene's output path says. The .blend itself
is never written.
"""
from __future__ import annotations

import sys

from ...model import cliargs
from ...model.dataset.exrio import stdout_to_stderr


def run(args) -> dict:
    from ..pipeline import render

    cfg = render.RenderConfig(blend=args.blend, out=args.out, frames=args.frames, model=args.model,
                              scene=args.scene, samples=args.samples, setup=args.setup, save_passes=args.save_passes,
                              runtime=args.runtime, device=args.device, working_res=args.working_res,
                              temporal=args.temporal)
    frames = len(args.frames) if args.frames else 1
    try:
        from tqdm import tqdm
        bar = tqdm(total=frames, unit="frame", file=sys.stderr, disable=frames < 2)
    except ImportError:
        bar = None
    try:
        with stdout_to_stderr():
            return render.run(cfg, progress=(lambda d: bar.update(1)) if bar is not None else None)
    finally:
        if bar is not None:
            bar.close()


def register_cli(sub) -> None:
    p = sub.add_parser("render", help="render a .blend's frames through the SSGI compositor node",
                       description="Render frames of a .blend with SSGI: EEVEE passes -> predicted global "
                                   "illumination -> the file's compositor -> image files in the scene's format.")
    p.add_argument("--blend", required=True, help="the .blend file (not modified)")
    p.add_argument("--out", default=None,
                   help="output path; '#' marks the frame number (as Blender's -o); default: the scene's output path")
    p.add_argument("--frames", type=cliargs.parse_frames, default=None,
                   help="frames to render: A-B, N or a list 1-3,7 (default: the scene's current frame)")
    p.add_argument("--model", default=None, type=cliargs.model_arg,
                   help=f"{cliargs.MODEL_HELP} (default: the SSGI node's, else the scene's, else default)")
    p.add_argument("--scene", default=None, help="scene name (default: the file's active scene)")
    p.add_argument("--samples", type=cliargs.positive_int, default=None,
                   help="EEVEE samples for the passes (default: the scene's render samples)")
    p.add_argument("--setup", action="store_true",
                   help="run Set up SSGI first (enable passes, insert the node) if the file lacks it")
    p.add_argument("--save-passes", default=None, metavar="DIR",
                   help="also write each frame's G-buffer (the model's input) as DIR/NNNNNN.exr (32-bit)")
    from .train import add_runtime_args
    add_runtime_args(p)
    p.add_argument("--working-res", type=cliargs.working_res, default=None, metavar="auto|full|Nx|WxH",
                   help="resolution the network predicts at, upsampled with the full-resolution G-buffer: auto "
                        "(from 960 px wide 1/4 per axis for a one-render model, else a working image 480 px wide; "
                        "below, full), full, 4x (1/4 per axis) or a size such as 480x270 (default: the SSGI node's "
                        "setting, else auto; docs/working_res.md)")
    p.add_argument("--temporal", choices=("auto", "on", "off"), default=None,
                   help="blend each frame with the motion-reprojected predictions of the frames before it (less "
                        "flicker): auto = on when more than one frame is rendered (default: the SSGI node's "
                        "setting, else auto; docs/temporal.md)")
    p.set_defaults(func=run)
