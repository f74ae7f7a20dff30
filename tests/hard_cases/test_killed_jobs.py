"""Hard cases 9 (killed jobs) and 10 (determinism) for the Blender jobs: `cli.py bake` and
`cli.py render` are killed with SIGKILL at a seeded random moment, a temporary file as a kill in the middle
of a write leaves it is added, and the same command is run again. Tiny sizes: real EEVEE and Cycles.

(The training kill is in test_training.py.)"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..conftest import clean, run_cli, run_py
from ..blender.test_node import room  # noqa: F401  (fixture: a 64x36, 3-frame room .blend with SSGI set up)
from .conftest import kill_at_random


def _no_temps(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.name.startswith(".") or ".tmp" in p.name)


# ------------------------------------------------------------------------------------------- bake

BAKE = ("--count", "3", "--seed", "11", "--size", "32x18", "--ref-samples", "2", "--no-denoise")


def _samples(folder: Path) -> dict:
    from ssgi.model.dataset import exrio
    return {p.stem: exrio.read_sample(p) for p in sorted(folder.glob("[0-9]*.exr"))}


def test_killed_bake_reruns_to_a_valid_dataset_with_the_same_pixels(tmp_path):
    """Cases 9 and 10: `cli.py bake` (3 rooms, 32x18) killed at a seeded random moment after its first
    sample, plus a temporary file as a kill in the middle of a write leaves it, then run again: the dataset
    is complete, `cli.py verify` passes, no temporary file is left, and every pixel of every sample equals
    an uninterrupted bake with the same seeds (same machine, same Blender)."""
    a, b = tmp_path / "a", tmp_path / "b"
    run_cli("bake", "--out", str(a), *BAKE, timeout=850)
    kill_at_random(["bake", "--out", str(b), *BAKE], lambda: (b / "000000.exr").is_file(), seed=5, span=4.0)
    (b / ".000002.exr.999999.tmp").write_bytes(b"half a sample")
    p = run_cli("bake", "--out", str(b), *BAKE, "--json", timeout=850)
    res = json.loads(p.stdout)
    assert res["baked"] + res["skipped"] == 3 and res["skipped"] >= 1 and res["removed_temp_files"] >= 1
    v = run_cli("verify", str(b), "--json", check=False)
    assert v.returncode == 0, clean(v.stderr)[-3000:]
    assert _no_temps(b) == []
    sa, sb = _samples(a), _samples(b)
    assert sorted(sa) == sorted(sb) == ["000000", "000001", "000002"]
    for k in sa:
        for g in sa[k]:
            np.testing.assert_array_equal(sa[k][g], sb[k][g], err_msg=f"sample {k} group {g}")
    ma, mb = (json.loads((d / "manifest.json").read_text()) for d in (a, b))
    strip = lambda m: {k: {kk: vv for kk, vv in s.items() if kk != "timings"} for k, s in m["samples"].items()}
    assert strip(ma) == strip(mb) and ma["settings"] == mb["settings"]
    assert all(np.std(s["ref"]) > 0 for s in sa.values())  # real rooms, not blank frames


# A write that fails in the middle of a bake (no mock: the OS refuses it). The first sample is baked, then
# either the process may write no more bytes (RLIMIT_FSIZE 0, as a full disk: Blender's save of the render to
# the temporary folder fails first) or the dataset folder is moved away (the sample's write fails).
_FAIL_AFTER_ONE = """
import os, resource, sys
from ssgi.ssgi_addon.pipeline import bake
from ssgi.model.errors import UserError
out, how = sys.argv[1], sys.argv[2]
def progress(info):
    if info["done"] == 1 and how == "full":
        resource.setrlimit(resource.RLIMIT_FSIZE, (0, resource.RLIM_INFINITY))  # SIGXFSZ: Python ignores it
    elif info["done"] == 1:
        os.rename(out, out + ".moved")
try:
    bake.run(bake.BakeConfig(out, count=3, seed=11, size=(32, 18), ref_samples=2), progress=progress)
except UserError as e:
    print(e)
    sys.exit(2)
"""


def test_a_write_failure_mid_bake_is_a_clear_error_and_the_same_command_resumes(tmp_path):
    """No data lost: a bake whose writes start failing after its first sample stops with a UserError that
    names the folder, the sample and the cause and says how many samples are complete; the first sample and
    the manifest are intact; the same bake run again (once the fault is mended) skips it and completes a
    dataset that `cli.py verify` passes, with no temporary file left."""
    for how, cause in (("full", "could not save the render in the temporary folder"), ("gone", "000001.exr: could not write the OpenEXR file")):
        out = tmp_path / how
        p = run_py(_FAIL_AFTER_ONE, str(out), how, check=False, timeout=850)
        assert p.returncode == 2, clean(p.stderr)[-3000:]
        msg = p.stdout
        assert f"--out {out}: could not bake sample 000001: " in msg and cause in msg, msg
        assert "The 1 sample(s) listed in manifest.json are complete" in msg and "Traceback" not in p.stderr
        if how == "gone":
            (tmp_path / "gone.moved").rename(out)
        first = (out / "000000.exr").read_bytes()
        assert json.loads((out / "manifest.json").read_text())["samples"].keys() == {"000000"}
        r = run_cli("bake", "--out", str(out), *BAKE[:-1], "--json", timeout=850)  # BAKE less --no-denoise
        res = json.loads(r.stdout)
        assert (res["baked"], res["skipped"]) == (2, 1), res
        assert (out / "000000.exr").read_bytes() == first
        v = run_cli("verify", str(out), "--json", check=False)
        assert v.returncode == 0, clean(v.stderr)[-3000:]
        assert _no_temps(out) == [] and sorted(p.name for p in out.glob("*.exr")) == \
            ["000000.exr", "000001.exr", "000002.exr"]


# ------------------------------------------------------------------------------------------- render

def test_killed_render_reruns_to_complete_valid_frames(room, tmp_path):
    """Case 9: `cli.py render` of 3 frames killed at a seeded random moment after its first frame, plus a
    temporary frame file as a kill in the middle of a write leaves it, then run again: every frame is a
    complete, readable 64x36 RGBA image with finite values, and no temporary file is left in the output
    folder."""
    from ssgi.model.dataset import exrio
    out = tmp_path / "frames"
    args = ["render", "--blend", str(room["blend"]), "--out", str(out / "f_####"), "--frames", "1-3", "--samples", "1"]
    kill_at_random(args, lambda: (out / "f_0001.exr").is_file(), seed=3, span=3.0)
    (out / ".f_0002.exr.999999.tmp").write_bytes(b"half a frame")
    p = run_cli(*args, "--json", timeout=850)
    assert json.loads(p.stdout)["files"] == [str(out / f"f_{f:04d}.exr") for f in (1, 2, 3)]
    for f in (1, 2, 3):
        planes, _ = exrio.read_exr(out / f"f_{f:04d}.exr")
        assert sorted(planes) == ["A", "B", "G", "R"]
        assert all(v.shape == (36, 64) and np.isfinite(v).all() for v in planes.values())
    assert _no_temps(out) == []


def test_temporary_render_files_of_killed_processes_are_swept(tmp_path):
    """A killed render can leave its ``ssgi-render-*.exr`` scratch file (``files.scratch``:
    ``.ssgi-render-RANDOM.exr.PID.tmp``) in the temporary folder (only in the short save-and-read window now).
    The next render process removes such files once their process is gone and they are 10 minutes old; files
    of live processes, fresh files and other files stay."""
    import os
    import subprocess
    import sys
    import time

    from ssgi.ssgi_addon.blender import passes
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    dead, old = child.pid, time.time() - 2 * passes.STALE_TEMP_S
    names = {f".ssgi-render-a.exr.{dead}.tmp": old, f".ssgi-passes-b.exr.{dead}.tmp": old,
             f".ssgi-render-c.exr.{dead}.tmp": None, f".ssgi-render-d.exr.{os.getpid()}.tmp": old,
             f".ssgi-render-e.exr.{os.getppid()}.tmp": old, ".ssgi-render-x.exr.tmp": old, "ssgi-render-x.exr": old,
             f".other.exr.{dead}.tmp": old, "other.exr": old}
    for n, t in names.items():
        (tmp_path / n).write_bytes(b"")
        if t:
            os.utime(tmp_path / n, (t, t))
    removed = passes.remove_stale_temp_files(tmp_path)
    assert sorted(removed) == sorted([f".ssgi-render-a.exr.{dead}.tmp", f".ssgi-passes-b.exr.{dead}.tmp"])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(set(names) - set(removed))
