"""Add the surround group (or, with --group sky, the sky group) to dataset folders baked before they held it
(ssgi_addon/pipeline/surround_fill.py).

    .venv/bin/python scripts/add_surround.py data/artist1 data/studio1
    .venv/bin/python scripts/add_surround.py --group sky data/artist1
"""
import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import cli  # noqa: E402

cli.load_package()
from ssgi.model.errors import UserError  # noqa: E402
from ssgi.ssgi_addon.pipeline.surround_fill import FILLABLE, add_group  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
ap.add_argument("dirs", nargs="+", metavar="DIR", help="dataset folders (merged: cli.py merge DIR first)")
ap.add_argument("--group", default="surround", choices=FILLABLE, help="the group to add (surround)")
a = ap.parse_args()
for d in a.dirs:
    try:
        r = add_group(d, a.group, log=lambda m: print(m, file=sys.stderr))
    except UserError as e:
        sys.exit(f"add_surround: {e}")
    print(json.dumps(r))
