"""`cli.py report`: the speed-against-error report, headless: the report stage
(ssgi_addon/pipeline/report.py) behind argparse.

    cli.py report --data DIR --models M1.pt M2.pt ... --out DIR [--max-scenes N] [--spp 1,2,4,...]
    cli.py report --scenes a.blend b.blend --models ... --out DIR [--size 240x135] [--ref-samples 256]

Evaluates every method on the same scenes (ssgi_addon/pipeline/report.py) and writes OUT/report.md,
OUT/report.json, OUT/pareto.png and OUT/examples.png. While it runs, OUT/report.partial.json holds the numbers
of the scenes done so far. Progress lines ``report: progress F eta Ss: ...`` go to stderr, or with
``--progress`` the JSON lines of ssgi_addon/runtime/progress.py (the "Report" button's job reads them);
``--json`` prints the summary on stdout.
"""
from __future__ import annotations

import shlex
import sys

from ...model import cliargs
from ..pipeline.report import ReportConfig
from . import progress_sink

DEFAULT_SPP = ",".join(map(str, ReportConfig.spp))
DEFAULT_SIZES = ",".join(ReportConfig.sizes)


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
    D = ReportConfig
    p = sub.add_parser("report", help="speed against error: every method on the same scenes, timed",
                       description="Render every evaluation scene with every method (EEVEE direct, EEVEE GI, the "
                                   "given models, Cycles raw and + OIDN at each spp, the reference) and write "
                                   "report.md, report.json, pareto.png and examples.png into --out.")
    p.add_argument("--data", type=cliargs.existing_dir, help="dataset folder (its validation scenes are evaluated)")
    p.add_argument("--scenes", nargs="+", type=cliargs.existing_file, metavar="FILE.blend",
                   help="evaluate these .blend files instead: baked first into OUT/data (cli.py bake --scenes: "
                        "each camera at the current frame)")
    p.add_argument("--models", nargs="+", type=cliargs.existing_model, required=True, metavar="MODEL",
                   help="model checkpoints: the network sizes and the linear baseline (cli.py train / baseline)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--max-scenes", type=cliargs.positive_int, default=D.max_scenes,
                   help="evaluate at most N scenes (default %(default)s)")
    p.add_argument("--split", choices=("val", "all"), default=D.split,
                   help="dataset scenes to evaluate: the validation split (default) or all")
    p.add_argument("--spp", type=spp_list, default=D.spp, help=f"Cycles ladder (default {DEFAULT_SPP})")
    p.add_argument("--size", type=cliargs.parse_size, default=None,
                   help="bake size with --scenes (default: the baker's, 240x135); a dataset's own size otherwise")
    p.add_argument("--ref-samples", type=cliargs.positive_int, default=None,
                   help="reference samples with --scenes, denoised with OIDN (default 64: two seeds agree to "
                        ">= 40 dB, docs/bake.md); a dataset's own setting otherwise")
    p.add_argument("--reference-scenes", type=cliargs.nonnegative_int, default=D.reference_scenes,
                   help="re-render the reference (another seed) on this many scenes, for its time (default %(default)s)")
    p.add_argument("--eevee-samples", type=cliargs.positive_int, default=D.eevee_samples,
                   help="EEVEE GI render samples, default quality (default %(default)s, Blender's default)")
    p.add_argument("--eevee-high-samples", type=cliargs.positive_int, default=D.eevee_high_samples,
                   help="EEVEE GI render samples, high quality (default %(default)s)")
    p.add_argument("--ssgi-samples", type=cliargs.positive_int, default=D.ssgi_samples,
                   help="EEVEE samples of the SSGI path's own renders (its G-buffer and EEVEE's other components, "
                        "'rest') for models that predict the diffuse part (default %(default)s)")
    p.add_argument("--sizes", type=size_list, default=D.sizes,
                   help=f"scaling sizes (default {DEFAULT_SIZES}); --sizes '' is not allowed: use --no-scaling")
    p.add_argument("--no-scaling", action="store_true", help="skip the scaling measurements")
    p.add_argument("--temporal-frames", type=cliargs.nonnegative_int, default=D.temporal_frames,
                   help="frames of the camera move for temporal stability (default %(default)s; 0 or 1 skips it)")
    p.add_argument("--temporal-ref-samples", type=cliargs.positive_int, default=None,
                   help="reference samples per frame of the camera move (default: the dataset's reference setting)")
    p.add_argument("--shot", default=None, metavar="SHOT.blend|builtin",
                   help="also measure the warped flicker of a shot (a camera move and a moving object): SSGI with "
                        "its temporal mode on and off, EEVEE GI, Cycles 1 spp + OIDN and at equal time, against "
                        "the reference (--temporal-ref-samples); 'builtin' builds a 24-frame shot (docs/temporal.md)")
    p.add_argument("--shot-frames", type=cliargs.parse_frames, default=None,
                   help="frames of --shot, e.g. 1-24 (default: its frame range)")
    p.add_argument("--shot-size", type=cliargs.parse_size, default=D.shot_size,
                   help="resolution of --shot (default 160x90)")
    p.add_argument("--threads", type=cliargs.positive_int, default=D.threads,
                   help="torch threads for the predictions (default %(default)s, the add-on's default)")
    p.add_argument("--working-res", type=cliargs.working_res, default=D.working_res, metavar="auto|full|Nx|WxH",
                   help="resolution the models predict at, as the SSGI node's setting (default %(default)s: from 960 "
                        "px wide 1/4 per axis for a one-render model, else a working image 480 px wide (1/2 at 960, "
                        "1/4 at 1920); below, full; docs/working_res.md)")
    p.add_argument("--no-fit-baseline", action="store_true",
                   help="with --data and no linear model among --models, do not fit one (closed form, seconds)")
    p.add_argument("--progress", action="store_true", help="progress as JSON lines on stderr (for the UI)")
    p.set_defaults(func=run)


def config(args) -> ReportConfig:
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    return ReportConfig(models=list(args.models), out=args.out, data=args.data, scenes=args.scenes,
                        max_scenes=args.max_scenes, split=args.split, spp=tuple(args.spp), size=args.size,
                        ref_samples=args.ref_samples, reference_scenes=args.reference_scenes,
                        eevee_samples=args.eevee_samples, eevee_high_samples=args.eevee_high_samples,
                        ssgi_samples=args.ssgi_samples, sizes=tuple(args.sizes), scaling=not args.no_scaling, temporal_frames=args.temporal_frames,
                        temporal_ref_samples=args.temporal_ref_samples, threads=args.threads,
                        shot=args.shot, shot_frames=args.shot_frames, shot_size=tuple(args.shot_size),
                        working_res=args.working_res,
                        fit_baseline=not args.no_fit_baseline,
                        command="cli.py " + " ".join(shlex.quote(a) for a in argv))


def run(args) -> dict:
    from ...model.dataset.exrio import stdout_to_stderr
    from ..pipeline import report

    cfg = config(args)
    with stdout_to_stderr():
        return report.run(cfg, progress=progress_sink(args))
