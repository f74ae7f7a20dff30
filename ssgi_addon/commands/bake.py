"""`cli.py bake`: the bake stage (ssgi_addon/pipeline/bake.py) behind argparse. (The dataset folder's tools,
`verify`, `merge` and `preview`, are commands/dataset.py: they need no Blender.)

    cli.py bake --out DIR [--count 10] [--seed 0] [--mode diffuse|artist] [--size 240x135] [--ref-samples N] [--denoise] [--shard i/n]
    cli.py bake --out DIR --scenes a.blend b.blend [--frames 1-48]
"""
from __future__ import annotations

import sys

from ...model import cliargs
from ...model.errors import UserError
from ..blender.reference import DEFAULT_REF_TARGET_DB, DENOISED_REF_SAMPLES
from ..pipeline.bake import BakeConfig


def run_bake(args) -> dict:
    from tqdm import tqdm

    from ...model.dataset.exrio import stdout_to_stderr
    from ..pipeline import bake

    cfg = BakeConfig(out=args.out, count=args.count, seed=args.seed, size=tuple(args.size),
                     ref_samples=args.ref_samples, ref_target_db=args.ref_target_db, denoise=args.denoise,
                     eevee_samples=args.eevee_samples, shard=args.shard, scenes=args.scenes, frames=args.frames,
                     mode=args.mode, gi_samples=args.gi_samples, rest_samples=args.rest_samples,
                     one_render=args.one_render)
    bar = None

    def on_start(ev):  # the bar shows from the start, not after the first (minutes-long) sample
        nonlocal bar
        bar = tqdm(total=ev["todo"], file=sys.stderr, unit="sample", desc="bake")

    def progress(info):
        post = dict(eevee=f"{info['eevee_s']:.1f}s", cycles=f"{info['cycles_s']:.1f}s", spp=info["ref_samples"])
        if info["ref_agreement_db"] is not None:
            post["dB"] = f"{info['ref_agreement_db']:.1f}"
        bar.set_postfix(post)
        bar.update(1)

    with stdout_to_stderr():
        res = bake.run(cfg, progress=progress, on_start=on_start)
    if bar:
        bar.close()
    print(f"bake: {res['baked']} baked, {res['skipped']} already complete, {res['total']} in all -> {res['out']}",
          file=sys.stderr)
    return res


def register_cli(sub) -> None:
    D = BakeConfig
    p = sub.add_parser("bake", help="bake random rooms (or your .blend scenes) into an EXR dataset",
                       description="Bake EEVEE direct-only G-buffer passes and a Cycles reference per sample into "
                                   "DIR/000000.exr ... + DIR/manifest.json. Run the same command again to resume.")
    p.add_argument("--out", required=True, metavar="DIR", help="dataset folder (created if missing)")
    p.add_argument("--count", type=cliargs.nonnegative_int, default=D.count,
                   help="number of random rooms (default %(default)s)")
    p.add_argument("--seed", type=int, default=D.seed,
                   help="seed of the first room; room i uses seed+i (default %(default)s)")
    p.add_argument("--mode", choices=("diffuse", "artist", "studio", "interior"), default=D.mode,
                   help="random rooms: 'diffuse' (diffuse primitives and lamps, the seed's) or 'artist' (Principled, "
                        "metal, glass, textures, emitters, sky and sun, exteriors) or 'studio' (a cyclorama in a dark "
                        "stage, softboxes) or 'interior' (bright plaster rooms; docs/artist_rooms.md) "
                        "(default %(default)s)")
    p.add_argument("--size", type=cliargs.parse_size, default=cliargs.Size(*D.size), metavar="WxH",
                   help="image size (default %(default)s)")
    p.add_argument("--ref-samples", type=cliargs.positive_int, default=D.ref_samples,
                   help="Cycles samples per pixel of the reference: the most it may take to reach --ref-target-db, or "
                        "exactly this many with --ref-target-db 0 or --denoise (default %(default)s)")
    p.add_argument("--ref-target-db", type=cliargs.nonnegative_float, default=None, metavar="DB",
                   help="render the raw reference as two halves of different seeds, doubling them until two such "
                        "references would agree to DB dB PSNR (halves' PSNR + 3.01); 0: a fixed --ref-samples "
                        f"(default {DEFAULT_REF_TARGET_DB:g}; with --denoise, 0)")
    p.add_argument("--denoise", dest="denoise", action="store_true", default=D.denoise,
                   help="denoise the reference with OpenImageDenoise (albedo+normal); recorded in the manifest. "
                        f"Measured: {DENOISED_REF_SAMPLES} spp + OIDN agrees as well as {D.ref_samples} raw"
                        + (" (default)" if D.denoise else ""))
    p.add_argument("--no-denoise", dest="denoise", action="store_false",
                   help="raw path-traced reference" + (" (default)" if not D.denoise else ""))
    p.add_argument("--eevee-samples", type=cliargs.positive_int, default=D.eevee_samples,
                   help="EEVEE render samples of the G-buffer (default %(default)s)")
    p.add_argument("--gi-samples", type=cliargs.nonnegative_int, default=0, metavar="N",
                   help="with --one-render, the samples of its one EEVEE render (default 0: no one-render bake)")
    p.add_argument("--one-render", action="store_true",
                   help="a one-render bake (needs --gi-samples N): the samples hold what one-render models read, from "
                        "EEVEE's render of the room with ray tracing and fast GI off and an area light standing in for "
                        "each planar emitter at N samples (its Combined image eevee_combined, rest, albedo, normal, "
                        "depth, emission, its Diffuse Direct eevee_local and Glossy Color gloss), and no world, soft "
                        "direct or emitter renders (docs/one_render.md)")
    p.add_argument("--rest-samples", type=cliargs.nonnegative_int, default=0, metavar="N",
                   help="the samples also hold EEVEE's rest (all it renders besides diffuse light) of the scene at its "
                        "own settings at N samples, as the node renders it, and its Glossy Color: what a shot fit's "
                        "reflection map corrects (default 0: no rest)")
    p.add_argument("--shard", type=cliargs.parse_shard, default=None, metavar="i/n",
                   help="bake only samples i, i+n, ... (0-based) into a shard manifest; join with `merge`")
    p.add_argument("--scenes", nargs="+", metavar="FILE.blend", help="bake these scenes' cameras instead of rooms")
    p.add_argument("--frames", type=cliargs.parse_frames, default=None, metavar="A-B",
                   help="frames of --scenes to bake (default: each scene's current frame)")
    p.set_defaults(func=run_bake)
