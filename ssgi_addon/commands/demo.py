"""`cli.py demo` (`make demo`): the demo stage (ssgi_addon/pipeline/demo.py) behind argparse.

    cli.py demo --out out/demo [--seed 7] [--size 240x135] [--ref-samples 128] [--model m.pt] [--json]
"""
from __future__ import annotations

import argparse

from ...model import cliargs
from ..pipeline.demo import DemoConfig


def run(args) -> dict:
    from ..pipeline import demo
    return demo.run(DemoConfig(out=args.out, seed=args.seed, size=tuple(args.size), samples=args.samples,
                               ref_samples=args.ref_samples, denoise=args.denoise, model=args.model,
                               exposure=args.exposure))


def register_cli(sub) -> None:
    D = DemoConfig
    p = sub.add_parser("demo", help="render a random room with SSGI, EEVEE GI and Cycles; write PNGs, seconds and PSNR",
                       description="SSGI's main job on one random room: the SSGI frame (shipped default model), "
                                   "EEVEE's own render with ray tracing and fast GI, Cycles 1 sample + "
                                   "OpenImageDenoise and the Cycles reference, as PNGs plus a side-by-side sheet; "
                                   "prints each image's seconds and PSNR against the reference. The seconds are "
                                   "those of one render each in one process, start-up costs (EEVEE's shader "
                                   "compilation) included.")
    p.add_argument("--out", default=D.out, help="output folder (default: %(default)s)")
    p.add_argument("--seed", type=cliargs.nonnegative_int, default=D.seed, help="room seed (default: %(default)s)")
    p.add_argument("--size", type=cliargs.parse_size, default=cliargs.Size(*D.size),
                   help="render size WIDTHxHEIGHT (default: %(default)s, the training size)")
    p.add_argument("--samples", type=cliargs.positive_int, default=D.samples,
                   help="EEVEE samples of the SSGI frame and of EEVEE's own GI render (default: %(default)s)")
    p.add_argument("--ref-samples", type=cliargs.nonnegative_int, default=D.ref_samples,
                   help="Cycles samples for the reference; 0 skips it (default: %(default)s)")
    p.add_argument("--denoise", action=argparse.BooleanOptionalAction, default=D.denoise,
                   help="denoise the Cycles reference with OpenImageDenoise (default: on)")
    p.add_argument("--model", default=None, type=cliargs.model_arg,
                   help=f"{cliargs.MODEL_HELP} (default: default)")
    p.add_argument("--exposure", type=cliargs.positive_float, default=D.exposure,
                   help="exposure of the PNG previews")
    p.set_defaults(func=run)
