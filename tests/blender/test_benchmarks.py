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
    assert {"fit_scenes.py", "node_bench.py", "ref_target.py", "results.py"} <= set(SCRIPTS)
    assert not list((ROOT / "docs").rglob("*.py"))


@pytest.mark.parametrize("module", ["scenes.artist", "scenes.shots"])
def test_each_scene_module_runs_from_the_repo_root(module):
    p = subprocess.run([sys.executable, "-m", module, "--help"], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert p.returncode == 0 and "--out" in p.stdout, clean(p.stderr)[-2000:]


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


def test_equal_time_measures_every_frame_and_resumes_where_it_was_killed(tmp_path):
    """benchmarks/equal_time.py on the ripple shot at 48x27 over 6 frames (2 withheld), the shipped model standing
    in for a fitted one: every frame of both methods is timed, the equal-time spp follows from the measured totals,
    the withheld frames are scored; a run with one SSGI frame and the equal-time stage taken out of its state
    renders exactly those again (and no other frame)."""
    import json
    import os

    env = dict(os.environ, PYTHONHASHSEED="0")
    blend = tmp_path / "ripple.blend"
    p = subprocess.run([sys.executable, "-c", f"""
import sys; sys.path.insert(0, {str(ROOT)!r})
from scenes import shots as shot_scenes
sc = shot_scenes.build("ripple", (48, 27), 6)
sc.eevee.taa_render_samples = 1
shot_scenes.save(sc, {str(blend)!r})
"""], capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode == 0, clean(p.stderr)[-2000:]
    out = tmp_path / "et"
    cmd = [sys.executable, str(ROOT / "benchmarks" / "equal_time.py"), "--blend", str(blend), "--model",
           str(ROOT / "models" / "ssgi_default.pt"), "--fit-minutes", "0.5", "--out", str(out), "--size", "48x27",
           "--frames", "1-6", "--withheld", "2,5", "--ref-samples", "4", "--probe-samples", "4", "--max-spp", "8"]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)
    assert p.returncode == 0, clean(p.stderr)[-3000:]
    r = json.loads((out / "equal_time.json").read_text())
    e, st = r["equal_time"], json.loads((out / "state.json").read_text())
    assert sorted(map(int, st["ssgi"]["seconds"])) == sorted(map(int, st["cycles1"]["seconds"])) == [1, 2, 3, 4, 5, 6]
    assert e["ssgi_s"] == sum(st["ssgi"]["seconds"].values()) > 0
    assert abs(e["budget_s"] - (30.0 + e["ssgi_s"]) / 6) < 1e-9
    line = e["line"]
    assert e["spp"] == min(8, max(1, int((e["budget_s"] - line["a"]) // line["b_per_spp"])))
    assert e["spp"] == 8  # tiny frames: the SSGI frame (several renders) buys Cycles more than the cap
    assert sorted(map(int, st["equal"]["seconds"])) == [2, 5] and st["equal"]["spp"] == e["spp"]
    assert set(r["scores"]["methods"]) == {"ssgi", "equal", "cycles1"}
    for m in r["scores"]["methods"].values():
        assert 5 < m["psnr"] < 80 and set(m["per_frame"]) == {"2", "5"}
    assert (out / "frame_0002.png").is_file() and (out / "ssgi").is_dir()
    # resume: frame 4's SSGI time and the equal-time stage are gone, as if the run had been killed there
    del st["ssgi"]["seconds"]["4"]
    del st["equal"]
    (out / "state.json").write_text(json.dumps(st))
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)
    assert p.returncode == 0, clean(p.stderr)[-3000:]
    import re
    done = re.findall(r"(?m)^\d\d:\d\d:\d\d (\w+) frame (\d+):", p.stderr)
    assert done == [("ssgi", "4"), ("equal", "2"), ("equal", "5")], clean(p.stderr)[-2000:]
    st2 = json.loads((out / "state.json").read_text())
    assert st2["ssgi"]["resumed_at"] == [4] and st2["cycles1"]["seconds"] == st["cycles1"]["seconds"]
