"""Bad arguments and files that show without Blender: a model argument that is not a model says what the file is
(never torch's advice to load it unsafely), `cli.py bench` checks its files before it times anything, and
`make setup` hides pip's noise but not its news.
The Blender-side ones (bake --ref-samples, render --out formats and --setup) are tests/blender/test_bad_arguments.py."""
from __future__ import annotations

import argparse
import shlex
import subprocess
import sys

import numpy as np
import pytest
import torch

from ssgi.model import cliargs
from ssgi.model.errors import UserError
from ssgi.model.infer import bench
from ssgi.model.learn import checkpoint

from ..conftest import ROOT

FIX = ROOT / "tests" / "fixtures"


def _not_models(d):
    from PIL import Image
    (d / "folder.pt").mkdir()
    (d / "notes.txt").write_text("my render settings: 64 spp")
    (d / "empty.pt").write_bytes(b"")
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(d / "image.png")
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(d / "photo.jpg")
    torch.save({"args": argparse.Namespace(lr=1)}, d / "pickled.pt")  # a torch file with a Python object
    return {  # file -> what the message must say it is
        d / "folder.pt": "a folder", d / "notes.txt": "a text file: 'my render settings: 64 spp'",
        d / "empty.pt": "an empty file", d / "image.png": "a PNG image", d / "photo.jpg": "a JPEG image",
        FIX / "predict_000000.exr": "an OpenEXR image", FIX / "ssgi_scene.blend": "compressed .blend",
        d / "pickled.pt": "a torch file holding Python objects other than tensors",
    }


def test_a_file_that_is_not_a_model_is_named_with_what_it_is(tmp_path):
    for path, what in _not_models(tmp_path).items():
        with pytest.raises(UserError) as e:
            checkpoint.load(path)
        msg = str(e.value)
        assert msg.startswith(f"{path}: not an SSGI model checkpoint (") and what in msg, msg
        assert "weights_only" not in msg and "no such" not in msg, msg
    with pytest.raises(UserError, match=r"nope\.pt: no such model file$"):
        checkpoint.load(tmp_path / "nope.pt")
    # a real checkpoint (a torch zip) is left to the loader
    assert cliargs.model_file_fault(FIX / "ssgi_tiny.pt") is None
    assert checkpoint.load(FIX / "ssgi_tiny.pt")["arch"]["variant"] == "unet_s"


def test_a_text_file_cut_inside_a_character_is_still_text(tmp_path):
    f = tmp_path / "notes.md"
    f.write_bytes(b"x" + "é".encode() * 600)  # 2 bytes each after the x: the 512-byte head ends inside one
    assert "a text file" in cliargs.model_file_fault(f)


def test_bench_checks_every_model_file_before_timing_anything(tmp_path, monkeypatch):
    timed = []
    monkeypatch.setattr(bench, "time_predictor", lambda *a, **k: timed.append(a) or pytest.fail("timed first"))
    notes = tmp_path / "notes.txt"
    notes.write_text("not a model")
    with pytest.raises(UserError, match="notes.txt: not an SSGI model checkpoint"):
        bench.bench(models=[FIX / "ssgi_tiny.pt", notes], sizes=("16x9",))
    with pytest.raises(UserError, match="unknown variant 'nope'"):
        bench.bench(variants=["unet_s", "nope"], sizes=("16x9",))
    with pytest.raises(UserError, match="--out .*does not exist"):
        bench.bench(variants=["unet_s"], sizes=("16x9",), out=str(tmp_path / "no" / "b.json"))
    assert timed == []


def test_setup_hides_pips_ignored_location_lines_and_keeps_the_rest():
    """scripts/setup.sh's quiet_pip, run with a stand-in pip: the ~40 "Location ... is ignored" lines go, any
    other warning and the errors stay, and pip's exit status is kept."""
    script = (ROOT / "scripts" / "setup.sh").read_text()
    start = script.index("PIP_NOISE=")
    fn = script[start:script.index("\n}\n", start) + 3]
    fake = ("import sys\n"
            "for p in ('bpy', 'certifi'):\n"
            "    print(f\"WARNING: Location 'file:///opt/pypi/simple/{p}/' is ignored: it is neither a file nor a "
            "directory.\", file=sys.stderr)\n"
            "print('WARNING: Retrying after a broken connection', file=sys.stderr)\n"
            "print('ERROR: No matching distribution found for bpy==9', file=sys.stderr)\n"
            "sys.exit(3)\n")
    code = fn + f"PIP=({shlex.quote(sys.executable)} -c {shlex.quote(fake)})\nquiet_pip -r x.lock; echo \"rc=$?\"\n"
    p = subprocess.run(["bash", "-c", code], capture_output=True, text=True, timeout=60)
    assert p.stdout.strip() == "rc=3", (p.stdout, p.stderr)
    assert "is ignored" not in p.stderr, p.stderr
    assert p.stderr.splitlines() == ["WARNING: Retrying after a broken connection",
                                     "ERROR: No matching distribution found for bpy==9"], p.stderr
