"""The scripts in benchmarks/ start through benchmarks/_bootstrap.py (the checkout as package ``ssgi``): each
parses its arguments (--help), and fit_scenes.py writes its scene. The measurements themselves are minutes
long and are not run here."""
from __future__ import annotations

import subprocess
import sys

import pytest

from ..conftest import ROOT, clean

SCRIPTS = sorted(p.name for p in (ROOT / "benchmarks").glob("*.py") if p.name != "_bootstrap.py")


def test_the_tool_scripts_live_in_benchmarks_and_docs_holds_no_python():
    assert {"fit_look.py", "fit_scenes.py", "node_bench.py", "ref_target.py"} <= set(SCRIPTS)
    assert not list((ROOT / "docs").rglob("*.py"))


@pytest.mark.parametrize("name", [n for n in SCRIPTS if n != "fit_scenes.py"])
def test_each_script_starts_and_parses_its_arguments(name):
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / name), "--help"], capture_output=True, text=True,
                       timeout=120, cwd=ROOT / "benchmarks")  # from another folder too: the bootstrap finds the checkout
    assert p.returncode == 0 and "usage:" in p.stdout, clean(p.stderr)[-2000:]


def test_fit_scenes_writes_the_cornell_scene(tmp_path):
    out = tmp_path / "cornell.blend"
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "fit_scenes.py"), "cornell", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and out.stat().st_size > 1000, clean(p.stderr)[-2000:]


def test_components_splits_the_emissive_cornell_box_into_diffuse_and_rest(tmp_path):
    """benchmarks/components.py on the emission-only Cornell box at 64x36: the panel is in EEVEE's rest (the
    G-buffer's diffuse light is black: no lamp objects) and in Cycles' rest alike, Cycles' diffuse part is lit, and the
    ceiling (Cycles' diffuse + EEVEE's rest) scores far above the no-network image (G-buffer + rest)."""
    import json

    from PIL import Image
    p = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "components.py"), "--names", "cornell_emissive",
                        "--size", "64x36", "--spp", "4", "--eevee-samples", "1", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, clean(p.stderr)[-2000:]
    (r,) = json.loads((tmp_path / "components.json").read_text())["scenes"]
    m = r["mean"]
    assert m["gbuffer_diffuse"] < 1e-3 < m["eevee_rest"], m
    assert m["cycles_diffuse"] > 0.2 * m["cycles_image"] > 0, m  # the panel's own light is most of the image
    assert abs(m["eevee_rest"] / m["cycles_rest"] - 1) < 0.2, m  # both renderers' rest: the panel, the ball
    assert r["ceiling"]["psnr"] > r["no_network"]["psnr"] + 5, r
    assert Image.open(tmp_path / "cornell_emissive.png").size == (3 * 64 + 8, 2 * 36 + 4)
