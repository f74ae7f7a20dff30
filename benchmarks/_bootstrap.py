"""What every script in benchmarks/ starts with: ``import _bootstrap`` (the script's own folder is on sys.path
when it runs as ``.venv/bin/python benchmarks/NAME.py``) makes the checkout importable as the package ``ssgi``,
as cli.py does; the helpers below are the Blender set-up the scripts share.

benchmarks/ holds measurements and tool scripts, not the extension: blender_manifest.toml's [build] leaves it
out of the zip (tests/unit/test_extension.py checks).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from scenes import empty_scene  # noqa: E402,F401  (importing scenes loads the checkout as package ssgi)


def rooms(seeds, size):
    """Build each random room of ``seeds`` in turn into one empty factory scene, rendered at ``size`` (w, h);
    yields (seed, scene)."""
    from ssgi.ssgi_addon.blender import passes, room
    scene = empty_scene()
    for seed in seeds:
        room.build_room(seed, scene)
        passes.set_resolution(scene, *size)
        yield seed, scene


def run_main(main) -> None:
    """``sys.exit(main())``, a UserError (bad input: a missing file, a wrong size) printed as one line, exit 2."""
    from ssgi.model.errors import UserError
    try:
        sys.exit(main())
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
