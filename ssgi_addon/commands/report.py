"""`cli.py report`: the speed-against-error report (issue 6), headless.

    cli.py report --data DIR --models M1.pt M2.pt ... --out DIR [--max-scenes N] [--spp 1,2,4,...]
    cli.py report --scenes a.blend b.blend --models ... --out DIR [--size 240x135] [--ref-samples 256]

Evaluates every method on the same scenes (ssgi_addon/report_run.py) and writes OUT/report.md,
OUT/report.json, OUT/pareto.png and OUT/examples.png (model/report.py). While it runs, OUT/report.partial.json
holds the numbers of the scenes done so far. Progress lines ``report: progress F eta Ss: ...`` go to stderr
(the "Report" button reads them); ``--json`` prints the summary on stdout.
"""
from __future__ import annotations

import math
import os
import re
import shlex
import sys
import time
from pathlib import Path

from ...model import cliargs
from ...model.errors import UserError

DEFAULT_SPP = "1,2,4,8,16,32,64,128"
DEFAULT_SIZES = "240x135,960x540,1920x1080"


def spp_list(text: str) -> tuple[int, ...]:
    """``"1,2,4"`` -> (1, 2, 4): distinct whole numbers >= 1, ascending."""
    items = [s for s in str(text).split(",")]
    vals = tuple(cliargs.positive_int(s) for s in items)
    if len(set(vals)) != len(vals) or list(vals) != sorted(vals):
        raise cliargs.ArgError(f"{text!r}: give distinct sample counts in ascending order, e.g. {DEFAULT_SPP}")
    return vals


def size_list(text: str) -> tuple[str, ...]:
    return tuple(str(cliargs.parse_size(s)) for s in str(text).split(","))


def register_cli(sub) -> None:
    p = sub.add_parser("report", help="speed against error: every method on the same scenes, timed",
                       description="Render every evaluation scene with every method (EEVEE direct, EEVEE GI, the "
                                   "given models, Cycles raw and + OIDN at each spp, the reference) and write "
                                   "report.md, report.json, pareto.png and examples.png into --out.")
    p.add_argument("--data", type=cliargs.existing_dir, help="dataset folder (its validation scenes are evaluated)")
    p.add_argument("--scenes", nargs="+", type=cliargs.existing_file, metavar="FILE.blend",
                   help="evaluate these .blend files instead: baked first into OUT/data (cli.py bake --scenes: "
                        "each camera at the current frame)")
    p.add_argument("--models", nargs="+", type=cliargs.existing_file, required=True, metavar="MODEL.pt",
                   help="model checkpoints: the network sizes and the linear baseline (cli.py train / baseline)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--max-scenes", type=cliargs.positive_int, default=6, help="evaluate at most N scenes (default 6)")
    p.add_argument("--split", choices=("val", "all"), default="val",
                   help="dataset scenes to evaluate: the validation split (default) or all")
    p.add_argument("--spp", type=spp_list, default=spp_list(DEFAULT_SPP), help=f"Cycles ladder (default {DEFAULT_SPP})")
    p.add_argument("--size", type=cliargs.parse_size, default=None,
                   help="bake size with --scenes (default: the baker's, 240x135); a dataset's own size otherwise")
    p.add_argument("--ref-samples", type=cliargs.positive_int, default=None,
                   help="reference samples with --scenes, denoised with OIDN (default 64: two seeds agree to "
                        ">= 40 dB, docs/bake.md); a dataset's own setting otherwise")
    p.add_argument("--reference-scenes", type=cliargs.nonnegative_int, default=1,
                   help="re-render the reference (another seed) on this many scenes, for its time (default 1)")
    p.add_argument("--eevee-samples", type=cliargs.positive_int, default=64,
                   help="EEVEE GI render samples, default quality (default 64, Blender's default)")
    p.add_argument("--eevee-high-samples", type=cliargs.positive_int, default=64,
                   help="EEVEE GI render samples, high quality (default 64)")
    p.add_argument("--sizes", type=size_list, default=size_list(DEFAULT_SIZES),
                   help=f"scaling sizes (default {DEFAULT_SIZES}); --sizes '' is not allowed: use --no-scaling")
    p.add_argument("--no-scaling", action="store_true", help="skip the scaling measurements")
    p.add_argument("--temporal-frames", type=cliargs.nonnegative_int, default=4,
                   help="frames of the camera move for temporal stability (default 4; 0 or 1 skips it)")
    p.add_argument("--temporal-ref-samples", type=cliargs.positive_int, default=None,
                   help="reference samples per frame of the camera move (default: the dataset's reference setting)")
    p.add_argument("--threads", type=cliargs.positive_int, default=1,
                   help="torch threads for the predictions (default 1, the add-on's default)")
    p.add_argument("--no-fit-baseline", action="store_true",
                   help="with --data and no linear model among --models, do not fit one (closed form, seconds)")
    p.set_defaults(func=run)


def run(args) -> dict:
    from .render import stdout_to_stderr
    with stdout_to_stderr():
        return _run(args)


def _out_dir(text: str) -> Path:
    out = Path(text).expanduser()
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"--out {out}: cannot create the folder ({e.strerror})") from None
    if not os.access(out, os.W_OK):
        raise UserError(f"--out {out}: the folder is not writable")
    return out


def default_model_key(keys_paths) -> str | None:
    """The shipped default model (models/ssgi_default.pt) when it is among the models, else the first network."""
    from ..blender.node import DEFAULT_MODEL
    for key, path, kind in keys_paths:
        if Path(path).resolve() == DEFAULT_MODEL.resolve():
            return key
    return next((key for key, _, kind in keys_paths if kind != "linear"), None)


def _bake_scenes(args, out: Path):
    """``--scenes``: bake the .blend files with the baker (bake --scenes: each scene camera at its current frame)
    into OUT/data (resumable), then evaluate every sample of it."""
    from ..pipeline import bake
    from ..pipeline import report as rr

    data = out / "data"
    size = tuple(args.size) if args.size else bake.DEFAULT_SIZE
    t = time.perf_counter()
    rr.log(f"baking {len(args.scenes)} .blend file(s) into {data} (cli.py bake --scenes)")
    res = bake.bake(data, scenes=[str(p) for p in args.scenes], size=size,
                    ref_samples=args.ref_samples or bake.DENOISED_REF_SAMPLES, denoise=True,
                    progress=lambda done, total, info: rr.log(f"bake {done}/{total}: {info}"))
    scenes, over, notes = rr.dataset_scenes(data, (), args.max_scenes, "all", per_sample=True)
    notes.append(f"--scenes: baked by ssgi_addon/bake.py into {data} ({res['baked']} baked, {res['skipped']} already "
                 f"there, {time.perf_counter() - t:.1f} s); every sample evaluated")
    return scenes, dict(over, source="--scenes " + " ".join(str(p) for p in args.scenes)), notes


def _run(args) -> dict:
    import bpy

    from ...model.infer import predictor
    from ...model.evaluate import record, report
    from ..pipeline import report as rr

    t_start = time.perf_counter()
    if not args.data and not args.scenes:
        raise UserError("give --data DIR (a dataset's validation scenes) or --scenes FILE.blend ...")
    out = _out_dir(args.out)
    machine = record.machine()
    notes: list[str] = []
    models = [Path(p) for p in args.models]
    preds = [(p, predictor.load_predictor(p, num_threads=args.threads)) for p in models]
    if args.data and not args.no_fit_baseline and not any(pr.kind == "linear" for _, pr in preds):
        from ...model.learn import baseline
        bl = out / "linear_baseline.pt"
        rr.log(f"no linear model given: fitting the linear-regression baseline on {args.data} -> {bl}")
        baseline.run_baseline(args.data, bl, log=rr.log)
        preds.append((bl, predictor.load_predictor(bl, num_threads=args.threads)))
        notes.append(f"the linear baseline was fitted by this run (model/baseline.py, closed form) on the training "
                     f"split of {args.data}: {bl}")
    n_net = sum(1 for _, pr in preds if pr.kind != "linear")
    if n_net < 3:
        notes.append(f"only {n_net} network size(s) given; issue 6 asks for at least 3 (small to large)")

    if args.scenes:
        scenes, over, n2 = _bake_scenes(args, out)
    else:
        if args.size or args.ref_samples:
            notes.append("--size and --ref-samples are ignored with --data: the dataset's own settings are used")
        scenes, over, n2 = rr.dataset_scenes(args.data, [pr.ckpt for _, pr in preds], args.max_scenes, args.split)
    notes += n2
    settings = rr.Settings(spp=tuple(args.spp), eevee_samples=args.eevee_samples,
                           eevee_high_samples=args.eevee_high_samples,
                           reference_scenes=min(args.reference_scenes, len(scenes)), threads=args.threads,
                           sizes=tuple(args.sizes), temporal_frames=args.temporal_frames,
                           temporal_ref_samples=args.temporal_ref_samples or over["ref_samples"], **over)
    rr.log(f"{len(scenes)} scene(s) at {settings.size[0]}x{settings.size[1]}, {len(preds)} model(s), "
           f"Cycles ladder {','.join(map(str, settings.spp))} spp")

    partial = out / "report.partial.json"
    runner = rr.ReportRun(scenes, preds, settings, partial=lambda raw: record.write_json(partial, raw))
    raw, images = runner.run()
    keys = [(k, p, pr.kind) for k, (p, pr) in runner._model_keys.items()]
    raw["default_model_key"] = default_model_key(keys)
    if not args.no_scaling:
        raw["scaling"] = runner.scaling(scenes[0], settings.sizes)
    if args.temporal_frames >= 2:
        raw["temporal"] = runner.temporal(scenes[0], raw["default_model_key"], args.temporal_frames)
    machine["loadavg_end"] = list(os.getloadavg())
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    raw.update(date=record.now(), command="cli.py " + " ".join(shlex.quote(a) for a in argv),
               machine=machine, versions=dict(record.versions(), blender=bpy.app.version_string),
               settings=settings.as_dict(), run_s=time.perf_counter() - t_start)
    raw["notes"] = raw.get("notes", []) + notes
    files = report.write_outputs(raw, images, out)
    if partial.exists():
        partial.unlink()
    rr.log(f"wrote {', '.join(files.values())} in {(time.perf_counter() - t_start) / 60:.1f} min")
    dk = raw.get("default_model_key")
    summ = {k: dict(label=m["label"], psnr=m["summary"].get("psnr"), whole_s=m["summary"].get("whole_s"),
                    own_s=m["summary"].get("own_s"))
            for k, m in raw["methods"].items() if m.get("summary")}
    res = dict(out=str(out), files=files, scenes=raw["scenes"], methods=summ, default_model=dk,
               run_s=raw["run_s"])
    if dk and raw["methods"][dk].get("equal_quality"):
        e = raw["methods"][dk]["equal_quality"]["whole"]
        res["default_speedup"] = None if not math.isfinite(e["speedup"]) else dict(
            speedup=e["speedup"], bound=e["bound"], winner=e["winner"])
    return res


# --------------------------------------------------------------------------------------------- the UI's job

JOB = "report"
PROGRESS_RE = re.compile(r"report: progress ([0-9.]+) eta (\S+?)s: (.*)$")


def command(data, models, out, max_scenes: int = 6, options: str = "") -> list[str]:
    """The ``cli.py report`` command line the Report button runs in a separate process: the bpy module's
    Python here, ``blender --background --python cli.py --`` in the Blender app (the user's file is never
    touched: the report opens and builds its own scenes)."""
    import bpy

    from .. import root_package
    root = Path(sys.modules[root_package()].__file__).resolve().parent
    head = ([sys.executable, str(root / "cli.py")] if getattr(bpy.app, "module", False)
            else [bpy.app.binary_path, "--background", "--python", str(root / "cli.py"), "--"])
    try:
        extra = shlex.split(options or "")
    except ValueError as e:
        raise UserError(f"report options {options!r}: {e}") from None
    return head + ["report", "--data", str(data), "--models", *map(str, models), "--out", str(out),
                   "--max-scenes", str(int(max_scenes)), *extra]


def start_job(cmd: list[str], out) -> "jobs.Job":
    """Run ``cmd`` (``command(...)``) in a background job: its progress lines become ``job.state`` (progress,
    eta_s, message); the result is the summary read back from OUT/report.json. Cancel ends the process."""
    import json

    from ..runtime import deps, jobs

    out = Path(out)

    def work(job):
        errors: list[str] = []

        def on_line(line: str) -> None:
            m = PROGRESS_RE.search(line)
            if m:
                eta = float(m.group(2)) if m.group(2) not in ("nan", "inf") else None
                job.report(progress=float(m.group(1)), eta_s=eta, message=m.group(3))
            elif line.startswith("report: "):
                job.report(message=line[len("report: "):])
            elif "error:" in line:
                errors.append(line)

        job.report(message="starting: " + " ".join(cmd[-8:]))
        code, tail = deps.run_pip(cmd, on_line=on_line, should_cancel=lambda: job.cancelled)
        job.check_cancel()
        if code != 0:
            last = errors[-1] if errors else ([l for l in tail.splitlines() if l.strip()] or ["(no output)"])[-1]
            raise UserError(f"cli.py report exited with status {code}: {last}")
        raw = json.loads((out / "report.json").read_text())
        res = dict(files=raw.get("files", {}), scenes=raw.get("scenes", []), run_s=raw.get("run_s"))
        dk = raw.get("default_model_key")
        if dk:
            res["verdict"] = (raw.get("verdicts", {}).get(dk) or [""])[0]
            res["default_model"] = raw["methods"][dk]["label"]
        return res

    return jobs.Job(JOB, work).start()


def status_text(state: dict) -> str:
    eta = state.get("eta_s")
    t = f" (about {eta / 60:.0f} min left)" if eta is not None and eta >= 60 else (
        f" ({eta:.0f} s left)" if eta is not None else "")
    return f"{100 * float(state.get('progress', 0.0)):.0f}%{t}: {state.get('message', '')}"[:140]
