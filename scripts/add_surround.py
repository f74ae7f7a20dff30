"""Add the surround group to dataset folders baked before it existed (ssgi_addon/pipeline/surround_fill.py).

    .venv/bin/python scripts/add_surround.py /work/data/artist1 /work/data/studio1
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import cli  # noqa: E402

cli.load_package()
from ssgi.model.errors import UserError  # noqa: E402
from ssgi.ssgi_addon.pipeline.surround_fill import add_surround  # noqa: E402

if len(sys.argv) < 2:
    sys.exit("usage: add_surround.py DIR [DIR ...]")
for d in sys.argv[1:]:
    try:
        r = add_surround(d, log=lambda m: print(m, file=sys.stderr))
    except UserError as e:
        sys.exit(f"add_surround: {e}")
    print(json.dumps(r))
