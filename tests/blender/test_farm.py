"""Farm rendering through Blender: ``farm_render.py`` (shipped at the extension's top level) run by workers as
``blender -b shot.blend -s A -e B -o OUT -P farm_render.py`` (the bpy module stands in for the binary: each worker is
a separate process that opens the file, takes the frame range and output path as -s, -e and -o leave them, and runs
the script as -P does). A six-frame moving shot with the shipped one-render model and the temporal mode: one worker,
two and three disjoint ranges, and a worker given ``-- --frames 4-6``, each in its own processes and folders, write
the same frames bit for bit; a file it cannot render exits 2 with one line."""
from __future__ import annotations


import numpy as np
import pytest

from ..conftest import ROOT, run_py
from .test_temporal import SCENE, _read_exr

SHOT = SCENE + r'''
import ssgi
sc = build(last=6)
ssgi.register()
if sys.argv[2] == "setup":
    assert bpy.ops.ssgi.setup(model="one_render") == {"FINISHED"}  # a shipped model by name
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
print("SHOT_START", sc.get("ssgi_shot_start"))
'''

# a worker: what `blender -b FILE -s A -e B -o OUT -F OPEN_EXR -P farm_render.py [-- ARGS]` does before the script runs
WORKER = r'''
import runpy, sys
import bpy
blend, a, b, out, extra = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5:]
bpy.ops.wm.open_mainfile(filepath=blend)
sc = bpy.context.scene
if a:
    sc.frame_start, sc.frame_end = int(a), int(b)  # -s A -e B
sc.render.filepath = out  # -o
sc.render.image_settings.file_format = "OPEN_EXR"  # -F OPEN_EXR
sys.argv = ["blender", "-b", blend, "-P", "farm_render.py"] + (["--"] + extra if extra else [])
try:
    runpy.run_path({script!r}, run_name="__main__")
    code = 0
except SystemExit as e:
    code = e.code
print("EXIT", code)
'''.replace("{script!r}", repr(str(ROOT / "farm_render.py")))


def _worker(blend, a, b, out, *extra, check=True):
    p = run_py(WORKER, str(blend), str(a), str(b), str(out / "f_####"), *extra, timeout=900, check=check)
    code = int(next(l for l in p.stdout.splitlines() if l.startswith("EXIT")).split()[1])
    return code, p


@pytest.fixture(scope="module")
def shot(tmp_path_factory):
    d = tmp_path_factory.mktemp("farm")
    blend = d / "shot.blend"
    p = run_py(SHOT, str(blend), "setup", timeout=300)
    assert "SHOT_START 1" in p.stdout  # Set up SSGI and the save stored the shot's first frame
    return d, blend


def test_frames_split_among_one_two_and_three_workers_equal_bit_for_bit(shot):
    d, blend = shot
    runs = {"1": [(1, 6)], "2": [(1, 3), (4, 6)], "3": [(1, 2), (3, 4), (5, 6)]}
    frames = {}
    for name, ranges in runs.items():
        for k, (a, b) in enumerate(ranges):
            out = d / f"run{name}_{k}"
            code, p = _worker(blend, a, b, out)
            assert code == 0, p.stderr[-3000:]
            assert "temporal on" in p.stderr and "shot from frame 1" in p.stderr
            for f in range(a, b + 1):
                frames[(name, f)] = _read_exr(out / f"f_{f:04d}.exr")
            assert sorted(x.name for x in out.glob("f_*.exr")) == [f"f_{f:04d}.exr" for f in range(a, b + 1)]
    # a worker given its frames after -- (the file's own range kept)
    out = d / "after_dashes"
    code, p = _worker(blend, "", "", out, "--frames", "4-6")
    assert code == 0, p.stderr[-3000:]
    for f in (4, 5, 6):
        frames[("dashes", f)] = _read_exr(out / f"f_{f:04d}.exr")
    for f in range(1, 7):
        one = frames[("1", f)]
        assert np.isfinite(one).all() and one[..., :3].mean() > 0.01
        for name in ("2", "3") + (("dashes",) if f >= 4 else ()):
            assert np.array_equal(frames[(name, f)], one), f"frame {f}: {name} worker(s) differ from one"
    # the temporal mode was on: frame 4 differs from its own stateless render (the mode off)
    run_py(r'''
import sys, bpy
from ssgi.ssgi_addon.pipeline import render
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
sc = bpy.context.scene
sc.render.image_settings.file_format = "OPEN_EXR"
render.RenderSession(sc, [4], out=sys.argv[2], temporal="off").run()
''', str(blend), str(d / "stateless_4.exr"), timeout=600)
    assert np.abs(_read_exr(d / "stateless_4.exr") - frames[("1", 4)]).mean() > 1e-4


def test_a_file_the_worker_cannot_render_exits_2_with_one_line(tmp_path):
    blend = tmp_path / "plain.blend"
    run_py(SHOT, str(blend), "no-setup", timeout=300)
    code, p = _worker(blend, 1, 2, tmp_path / "out", check=False)
    lines = [l for l in p.stderr.splitlines() if l.startswith("SSGI farm: error")]
    assert code == 2 and len(lines) == 1 and "no SSGI node" in lines[0], p.stderr[-2000:]
    assert "Traceback" not in p.stderr
    code, p = _worker(blend, "", "", tmp_path / "out", "--frames", "x-y", check=False)
    assert code == 2 and "--frames" in p.stderr
