"""`cli.py fit`: fit a small model to one scene (the fit stage, ssgi_addon/pipeline/fit.py).

    cli.py fit --blend shot.blend --out shot_ssgi.pt [--views 24] [--minutes 15] [--target-psnr P] [--size 240x135]
    cli.py fit --blend shot.blend --out shot_ssgi.pt --frames 1-48    # a shot: 5 whole frames withheld and scored

Writes MODEL (a normal checkpoint whose input spec lists only the kept passes), MODEL.fit_report.json/.md
beside it, and a work folder MODEL.fit/ (views-TAG.blend: the copy with the jittered cameras; views-TAG/: the
baked views; views_plan.json: which camera is held out; the candidates' checkpoints). ``--data DIR`` fits
views baked before (roles from ``--plan``). ``--progress`` writes JSON progress lines on stderr (the UI's job).
"""
from __future__ import annotations

import re

from ...model import cliargs
from ..pipeline.fit import FitSceneConfig
from . import command_line, progress_sink


def _also(values):
    """--also-init: None (not given: the default rule), [] for "none", else the files."""
    if values is None:
        return None
    return [] if [v.lower() for v in values] == ["none"] else list(values)


def config(args) -> FitSceneConfig:
    return FitSceneConfig(out=args.out, blend=args.blend, data=args.data, plan=args.plan, scene=args.scene,
                          views=args.views, minutes=args.minutes, target_psnr=args.target_psnr, size=args.size,
                          init=args.init, also_init=_also(args.also_init), drop_tol=args.drop_tol, ref_samples=args.ref_samples,
                          crop=args.crop, batch=args.batch,
                          min_run_s=args.min_run_seconds, threads=args.threads, seed=args.seed,
                          frames=args.frames, rest_samples=args.rest_samples, lightmap=not args.no_lightmap,
                          reflmap=not args.no_reflmap, one_render=args.one_render,
                          command=command_line())


def run(args) -> dict:
    from ...model.dataset.exrio import stdout_to_stderr
    from ..pipeline import fit

    cfg = config(args)
    sink = progress_sink(args)
    progress = (lambda d: sink({"eta_s": d.get("left_s"), **d})) if sink else None  # the budget left is the ETA
    with stdout_to_stderr():
        return fit.run(cfg, progress=progress)


def shot_range(text: str) -> tuple[int, int]:
    """``"A-B"`` -> (A, B): a shot's first and last frame (views.check_shot judges the range)."""
    m = re.fullmatch(r"\s*(-?\d+)\s*-\s*(-?\d+)\s*", str(text))
    if not m:
        raise cliargs.ArgError(f"{text!r} is not a frame range A-B (e.g. 1-48)")
    a, b = int(m.group(1)), int(m.group(2))
    if b < a:
        raise cliargs.ArgError(f"{text!r}: the shot ends before it starts ({b} < {a})")
    return a, b


def register_cli(sub) -> None:
    D = FitSceneConfig
    p = sub.add_parser("fit", help="fit a small model to one scene: views, size and input selection",
                       description="Bake views of a scene (its cameras and animation frames plus jittered cameras, "
                                   "some held out), then fine-tune the shipped model or train small networks from "
                                   "scratch, keep the smallest that reaches the target PSNR on held-out views, "
                                   "drop the input passes the scene does not need, and report. MODEL.fit_report.md "
                                   "holds the table that led to the choice.")
    p.add_argument("--blend", help="the scene's .blend file (not modified)")
    p.add_argument("--out", required=True, metavar="MODEL", help="checkpoint to write (.pt)")
    p.add_argument("--views", type=cliargs.positive_int, default=D.views,
                   help="about how many views to bake (default %(default)s)")
    p.add_argument("--minutes", type=cliargs.positive_float, default=D.minutes,
                   help="the whole time budget, bake included (default %(default)s)")
    p.add_argument("--target-psnr", type=float, default=None, metavar="DB",
                   help="val PSNR to reach (default: the generic model's + 2 dB, or 30 dB without one)")
    p.add_argument("--size", type=cliargs.parse_size, default=None, metavar="WxH",
                   help="views' size (default: 240 wide at the scene's aspect ratio)")
    p.add_argument("--scene", default=None, help="scene name (default: the file's active scene)")
    p.add_argument("--frames", type=shot_range, default=None, metavar="A-B",
                   help="fit the shot A..B (within the scene's frame range, at least 20 frames): 5 whole frames spread "
                        "over it are withheld (nothing baked within a frame of them) and scored after the fit as the "
                        "node renders them, beside the generic model and Cycles 1 spp + OIDN")
    p.add_argument("--init", default=None, metavar="MODEL",
                   help="checkpoint to fine-tune from (default: the shipped models/ssgi_default.pt when present)")
    p.add_argument("--also-init", action="append", default=None, metavar="MODEL",
                   help="another checkpoint to start from: each start is fine-tuned briefly and the best on the "
                        "validation views goes on (repeatable; default for a shot fit without --init: the shipped "
                        "models/ssgi_fit_start.pt; --also-init none probes nothing)")
    p.add_argument("--drop-tol", type=float, default=D.drop_tol, metavar="DB",
                   help="drop an input pass when the val PSNR without it is at most this much lower (default %(default)s)")
    p.add_argument("--ref-samples", type=cliargs.positive_int, default=D.ref_samples,
                   help="Cycles samples of the views' references, denoised with OIDN (default %(default)s)")
    p.add_argument("--data", default=None, metavar="DIR", help="fit views baked before instead of baking --blend")
    p.add_argument("--plan", default=None, metavar="JSON", help="with --data: the views_plan.json of that bake")
    p.add_argument("--crop", type=cliargs.positive_int, default=None, help="training crop size (default 64)")
    p.add_argument("--batch", type=cliargs.positive_int, default=None, help="training batch (default 16)")
    p.add_argument("--min-run-seconds", type=cliargs.positive_float, default=None, metavar="S",
                   help="shortest training run worth starting (default 5; lower only for tiny test budgets)")
    p.add_argument("--threads", type=cliargs.positive_int, default=None, help="torch threads")
    p.add_argument("--seed", type=int, default=D.seed)
    p.add_argument("--no-reflmap", action="store_true",
                   help="a shot fit (--frames) fits no reflection map beside the model (model/infer/reflmap.py), and "
                        "its views hold no EEVEE rest for it")
    p.add_argument("--no-lightmap", action="store_true",
                   help="a shot fit (--frames) fits no lightmap beside the model (model/infer/lightmap.py)")
    p.add_argument("--rest-samples", type=cliargs.positive_int, default=None, metavar="N",
                   help="a shot fit's EEVEE samples of the views' rest, which its reflection map corrects (with "
                        "--one-render: of the one render; default: the scene's own, as the node renders it; fewer make "
                        "the bake cheaper)")
    p.add_argument("--one-render", action="store_true",
                   help="fit a one-render model: each frame of the node is then ONE EEVEE render with ray tracing and "
                        "fast GI off (the network and the shot's lightmap give the GI), at about the cost of EEVEE's "
                        "own GI render at the same samples (docs/one_render.md); the views hold that render's passes "
                        "and the fit trains small networks from scratch on its Combined image, so the frames render no "
                        "Diffuse Direct pass (a glossy shot's reflection map then corrects only where the albedo is "
                        "black: metal, mirrors)")
    p.add_argument("--progress", action="store_true", help="progress as JSON lines on stderr (for the UI)")
    p.set_defaults(func=run)
