"""`cli.py verify`, `merge`, `preview`: the dataset folder's tools (model/dataset/) behind argparse. No Blender is
needed: they run where only numpy and OpenEXR are installed (a training node).

    cli.py verify DIR | cli.py merge DIR | cli.py preview DIR --out SHEET.png
"""
from __future__ import annotations

import sys

from ...model import cliargs
from ...model.errors import UserError


def run_verify(args) -> dict:
    from ...model.dataset import folder as ds
    problems = ds.verify(args.folder)
    for p in problems:
        print(f"verify: {p}", file=sys.stderr)
    n = 0
    try:
        n = len(ds.open_folder(args.folder)["samples"])
    except UserError:
        pass
    if problems:
        raise UserError(f"{args.folder}: {len(problems)} problem(s) found (listed above)")
    print(f"verify: {args.folder}: {n} samples, all good", file=sys.stderr)
    return {"folder": str(args.folder), "samples": n, "problems": problems}


def run_merge(args) -> dict:
    from ...model.dataset import folder as ds
    res = ds.merge(args.folder)
    print(f"merge: {res['samples']} samples from {len(res['shards'])} shard manifest(s)", file=sys.stderr)
    return res


def run_preview(args) -> dict:
    from ...model.dataset import preview
    res = preview.preview(args.folder, args.out, max_samples=args.max)
    print(f"preview: {res['sheet']} ({res['samples']} samples)", file=sys.stderr)
    return res


def register_cli(sub) -> None:
    v = sub.add_parser("verify", help="check a dataset folder", description="Check counts, channel names and "
                       "sizes, finite values and the manifest against the files; names each problem file.")
    v.add_argument("folder", metavar="DIR")
    v.set_defaults(func=run_verify)

    m = sub.add_parser("merge", help="join shard manifests into manifest.json",
                       description="Join the manifests of `bake --shard i/n` runs in DIR into DIR/manifest.json.")
    m.add_argument("folder", metavar="DIR")
    m.set_defaults(func=run_merge)

    pv = sub.add_parser("preview", help="write a contact sheet of a dataset",
                        description="Per sample: the passes and the reference, tonemapped, in one PNG.")
    pv.add_argument("folder", metavar="DIR")
    pv.add_argument("--out", required=True, metavar="SHEET.png")
    pv.add_argument("--max", type=cliargs.positive_int, default=12, help="samples to show (default 12)")
    pv.set_defaults(func=run_preview)
