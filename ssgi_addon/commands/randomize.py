"""`cli.py randomize`: the randomize stage (ssgi_addon/pipeline/randomize.py) behind argparse.

    cli.py randomize [--seed 0] [--mode diffuse|artist] [--save room.blend] [--json]
"""
from __future__ import annotations

from ..pipeline.randomize import RandomizeConfig


def run(args) -> dict:
    from ...model.dataset.exrio import stdout_to_stderr
    from ..pipeline import randomize

    cfg = RandomizeConfig(seed=args.seed, save=args.save, mode=args.mode)
    with stdout_to_stderr():  # Blender prints "Info: Saved as ..." on stdout; stdout is for --json
        return randomize.run(cfg)


def register_cli(sub) -> None:
    p = sub.add_parser("randomize", help="build a random room scene from a seed",
                       description="Build a random room (box, primitives, lights, camera) from --seed.")
    p.add_argument("--seed", type=int, default=RandomizeConfig.seed, help="room seed (default %(default)s)")
    p.add_argument("--mode", choices=("diffuse", "artist", "studio", "interior"), default=RandomizeConfig.mode,
                   help="diffuse: box of diffuse primitives and lamps; artist: glossy, metal, glass, textured "
                        "materials, emitters, skies, open rooms and exteriors; studio: cycloramas lit by softboxes; "
                        "interior: bright plaster rooms "
                        "(docs/artist_rooms.md) "
                        "(default %(default)s)")
    p.add_argument("--save", metavar="FILE.blend", help="save the scene to this .blend file")
    p.set_defaults(func=run)
