"""`cli.py setup`: Set up SSGI in a copy of a .blend (ssgi_addon/pipeline/setup.py) behind argparse.

    cli.py setup --blend shot.blend --out shot_ssgi.blend [--model m.pt] [--compiled] [--json]

``--compiled`` sets the model (a boxmlp checkpoint) up as Blender's own compositor nodes: the copy renders SSGI
with plain F12 or ``blender -b shot_ssgi.blend -a``, without the extension (docs/compiled.md).
"""
from __future__ import annotations

from ...model import cliargs
from ...model.dataset.exrio import stdout_to_stderr


def run(args) -> dict:
    from ..pipeline import setup

    cfg = setup.SetupConfig(blend=args.blend, out=args.out, model=args.model, compiled=args.compiled, scene=args.scene)
    with stdout_to_stderr():
        return setup.run(cfg)


def register_cli(sub) -> None:
    p = sub.add_parser("setup", help="set SSGI up in a copy of a .blend (--compiled: renders without the extension)",
                       description="Set up SSGI in a copy of a .blend: the extension's SSGI node, or with --compiled "
                                   "the model as Blender's own compositor nodes, which plain Blender renders.")
    p.add_argument("--blend", required=True, help="the .blend file (not modified)")
    p.add_argument("--out", required=True, help="the copy to write (.blend)")
    p.add_argument("--model", default=None, type=cliargs.model_arg,
                   help=f"{cliargs.MODEL_HELP} (default: the file's SSGI node's, else its scene's, else default; "
                        f"--compiled: a boxmlp checkpoint)")
    p.add_argument("--compiled", action="store_true",
                   help="the model as compositor nodes (a plain render shows SSGI, no extension needed)")
    p.add_argument("--scene", default=None, help="scene name (default: the file's active scene)")
    p.set_defaults(func=run)
