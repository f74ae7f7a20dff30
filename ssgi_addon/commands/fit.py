"""`cli.py fit`: fit a small model to one scene: bake views of it, choose the size and the inputs, report.

    cli.py fit --blend shot.blend --out shot_ssgi.pt [--views 24] [--minutes 15] [--target-psnr P] [--size 240x135]

Writes MODEL (a normal checkpoint whose input spec lists only the kept passes), MODEL.fit_report.json/.md
beside it, and a work folder MODEL.fit/ (views-TAG.blend: the copy with the jittered cameras; views-TAG/: the
baked views; views_plan.json: which camera is held out; the candidates' checkpoints). TAG hashes the .blend's
bytes and the plan: the same command on an unchanged file reuses the views already baked (the baker
resumes); an edited file gets new views. ``--data DIR`` fits views baked before (roles from
``--plan``, or: cameras named ssgi.fit.view_* held out as make_views does). The .blend itself is never written.
``--minutes`` is the whole budget, bake included.
"""
from __future__ import annotations

import json
import random
import shlex
import sys
import time
from pathlib import Path

from ...model import cliargs, files
from ...model.errors import UserError


MIN_FIT_MINUTES = 0.5


def _command() -> str:
    return " ".join(shlex.quote(a) for a in [sys.executable] + sys.argv)


def work_dir(out) -> Path:
    o = Path(out)
    return o.with_name(o.stem + ".fit")


def derive_plan(data_dir, seed: int = 0) -> dict:
    """Roles for a views folder without a plan: jittered cameras (ssgi.fit.view_*) held out as make_views
    does; when there are none, every camera counts as a view point and the roles are drawn among all."""
    from ...model.dataset import folder
    from ..pipeline import fit as sfit
    m = folder.open_folder(data_dir, scenes=True)
    cams = sorted({sfit.sample_camera(s) for s in m["samples"].values()} - {None})
    jit = [c for c in cams if c.startswith(sfit.VIEW_PREFIX)] or cams
    if len(jit) < 3:
        raise UserError(f"{data_dir}: views of {len(jit)} camera(s); holding out validation and test views needs 3 or more")
    roles = dict(zip(jit, sfit.roles(len(jit), random.Random(seed))))
    return dict(cameras={c: roles.get(c, "train") for c in cams}, frames=None, derived=True)


def run(args) -> dict:
    from .render import stdout_to_stderr
    with stdout_to_stderr():
        return _run(args)


def _run(args) -> dict:
    from ..pipeline import fit as sfit
    from ..runtime.progress import emit

    t0 = time.perf_counter()
    out = Path(args.out).expanduser().resolve()
    if out.suffix != ".pt":
        raise UserError(f"--out {args.out}: the model file must end in .pt")
    if not out.parent.is_dir():
        raise UserError(f"--out {args.out}: folder {out.parent} does not exist")
    fault = cliargs.model_file_fault(args.init) if args.init else None
    if fault:  # before any baking
        raise UserError(f"--init {args.init}: {fault}")
    work = work_dir(out)

    def progress(d):
        if args.progress:  # the budget left is the job's time left
            emit(**{"eta_s": d.get("left_s"), **d})

    bake_s = 0.0
    if args.data:
        data_dir = Path(args.data)
        plan = json.loads(Path(args.plan).read_text()) if args.plan else derive_plan(data_dir, args.seed)
    else:
        if not args.blend:
            raise UserError("give --blend FILE (the scene to fit) or --data DIR (views baked before)")
        import bpy

        from ..blender.blendfile import check_blend, open_blend, pick_scene
        blend = check_blend(args.blend)
        open_blend(blend)
        scene = pick_scene(blend, args.scene)
        if bpy.context.window is not None and bpy.context.scene != scene:
            bpy.context.window.scene = scene
        progress(dict(phase="views", message="adding jittered cameras", progress=0.0))
        plan = sfit.make_views(scene, args.views, args.seed)
        size = tuple(args.size) if args.size else sfit.default_size(scene)
        plan.update(size=list(size), blend=str(blend))
        work.mkdir(parents=True, exist_ok=True)
        # views of THIS file with THESE settings: an edited scene gets new views, an unchanged one resumes
        tag = _views_tag(blend, plan)
        wblend = work / f"views-{tag}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(wblend), copy=True)
        files.write_json(work / "views_plan.json", plan, default=str)
        data_dir = work / f"views-{tag}"
        progress(dict(phase="bake", message=f"baking {len(plan['cameras']) * len(plan['frames'])} views", progress=0.0))
        sfit.bake_views(wblend, data_dir, plan, size, ref_samples=args.ref_samples)
        bake_s = time.perf_counter() - t0
        print(f"fit: views baked in {bake_s / 60:.2f} min", file=sys.stderr, flush=True)
    train, val, test = _split(data_dir, plan)

    from ...model.learn import fit as mfit
    from ..blender.node import DEFAULT_MODEL
    init = args.init or (str(DEFAULT_MODEL) if DEFAULT_MODEL.is_file() else None)
    left = 60.0 * args.minutes - (time.perf_counter() - t0)
    floor = max(0.1 * 60.0 * args.minutes, 60.0 * MIN_FIT_MINUTES)  # a bake that ate the budget still gets a fit
    fit_minutes = max(left, floor) / 60.0
    if left < floor:
        print(f"fit: the bake took {bake_s / 60:.2f} of {args.minutes:g} min; fitting gets {fit_minutes:.2f} min "
              "(the whole fit will run over the budget)", file=sys.stderr, flush=True)
    cfg = mfit.FitConfig(data=str(data_dir), out=str(out), train_keys=train, val_keys=val, test_keys=test,
                         minutes=fit_minutes, target_psnr=args.target_psnr, init=init, threads=args.threads,
                         seed=args.seed, drop_tol=args.drop_tol, command=_command())
    if args.ladder:
        cfg.ladder = _ladder(args.ladder)
    if args.crop:
        cfg.crop = args.crop
    if args.min_run_seconds:
        cfg.min_run_s = args.min_run_seconds
    res = mfit.fit(cfg, callback=progress)
    res.update(bake_minutes=bake_s / 60.0, total_minutes=(time.perf_counter() - t0) / 60.0, views=str(data_dir),
               init=init)
    if res.get("report"):  # the bake's share belongs in the report too
        rp = Path(res["report"])
        rep = json.loads(rp.read_text())
        rep.update(bake_minutes=res["bake_minutes"], total_minutes=res["total_minutes"])
        files.write_json(rp, rep, default=str)
    return res


def _views_tag(blend: Path, plan: dict) -> str:
    """8 hex digits naming the .blend's bytes and the plan (cameras, frames, size, seed)."""
    import hashlib
    h = hashlib.sha256()
    with open(blend, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    h.update(json.dumps({k: plan.get(k) for k in ("scene", "frames", "cameras", "size", "seed", "radius")},
                        sort_keys=True).encode())
    return h.hexdigest()[:8]


def _split(data_dir, plan):
    from ..pipeline import fit as sfit
    return sfit.split_views(data_dir, plan)


def _ladder(text: str) -> list:
    try:
        v = json.loads(text)
        assert isinstance(v, list) and all(isinstance(r, list) and len(r) == 3 for r in v)
        return v
    except (ValueError, AssertionError):
        raise UserError(f"--ladder must be a JSON list of [name, variant, {{overrides}}], got {text!r}") from None


def register_cli(sub) -> None:
    p = sub.add_parser("fit", help="fit a small model to one scene: views, size and input selection",
                       description="Bake views of a scene (its cameras and animation frames plus jittered cameras, "
                                   "some held out), then fine-tune the shipped model or train small networks from "
                                   "scratch, keep the smallest that reaches the target PSNR on held-out views, "
                                   "drop the input passes the scene does not need, and report. MODEL.fit_report.md "
                                   "holds the table that led to the choice.")
    p.add_argument("--blend", help="the scene's .blend file (not modified)")
    p.add_argument("--out", required=True, metavar="MODEL", help="checkpoint to write (.pt)")
    p.add_argument("--views", type=cliargs.positive_int, default=24, help="about how many views to bake (default %(default)s)")
    p.add_argument("--minutes", type=cliargs.positive_float, default=15.0,
                   help="the whole time budget, bake included (default %(default)s)")
    p.add_argument("--target-psnr", type=float, default=None, metavar="DB",
                   help="val PSNR to reach (default: the generic model's + 2 dB, or 30 dB without one)")
    p.add_argument("--size", type=cliargs.parse_size, default=None, metavar="WxH",
                   help="views' size (default: 240 wide at the scene's aspect ratio)")
    p.add_argument("--scene", default=None, help="scene name (default: the file's active scene)")
    p.add_argument("--init", default=None, metavar="MODEL",
                   help="checkpoint to fine-tune from (default: the shipped models/ssgi_default.pt when present)")
    p.add_argument("--drop-tol", type=float, default=0.1, metavar="DB",
                   help="drop an input pass when the val PSNR without it is at most this much lower (default %(default)s)")
    p.add_argument("--ref-samples", type=cliargs.positive_int, default=None,
                   help="Cycles samples of the views' references (default 16 + OIDN: fit.FIT_REF_SAMPLES)")
    p.add_argument("--data", default=None, metavar="DIR", help="fit views baked before instead of baking --blend")
    p.add_argument("--plan", default=None, metavar="JSON", help="with --data: the views_plan.json of that bake")
    p.add_argument("--ladder", default=None, metavar="JSON", help='sizes to try, e.g. \'[["xs", "unet", {"widths": [8, 12, 16], "convs": [1, 1, 1]}]]\'')
    p.add_argument("--crop", type=cliargs.positive_int, default=None, help="training crop size (default 64)")
    p.add_argument("--min-run-seconds", type=cliargs.positive_float, default=None, metavar="S",
                   help="shortest training run worth starting (default 5; lower only for tiny test budgets)")
    p.add_argument("--threads", type=cliargs.positive_int, default=None, help="torch threads")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--progress", action="store_true", help="progress as JSON lines on stderr (for the UI)")
    p.set_defaults(func=run)
