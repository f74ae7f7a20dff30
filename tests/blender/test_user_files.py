"""User files made by an older SSGI (tests/fixtures/, commit 4187f74) on real Blender: `cli.py verify` accepts the
old dataset folder, and the old .blend, set up with the SSGI node and its model beside it (``//ssgi_tiny.pt``),
renders through that node what the old model predicts from the frame's passes. The bpy-free side (load,
predict as then, train, resume) is tests/unit/test_user_files.py."""
from __future__ import annotations

import hashlib
import json

import numpy as np

from ..conftest import ROOT, run_cli
from .test_node import expected_image, read_rgba

FIX = ROOT / "tests" / "fixtures"


def test_cli_verify_accepts_the_old_dataset():
    before = {p.name: p.read_bytes() for p in (FIX / "dataset").iterdir()}
    r = json.loads(run_cli("verify", str(FIX / "dataset"), "--json", timeout=300).stdout)
    assert r["problems"] == [], r
    assert {p.name: p.read_bytes() for p in (FIX / "dataset").iterdir()} == before  # verify only reads


def test_the_old_blend_renders_its_models_prediction_through_the_ssgi_node(tmp_path):
    blend = FIX / "ssgi_scene.blend"
    sha = hashlib.sha256(blend.read_bytes()).hexdigest()
    p = run_cli("render", "--blend", str(blend), "--out", str(tmp_path / "frame.exr"), "--save-passes",
                str(tmp_path / "passes"), "--json", timeout=300)
    s = json.loads(p.stdout)
    assert s["model"] == str(FIX / "ssgi_tiny.pt") and s["inputs"] == "albedo,normal,depth,direct,lit"
    from ssgi.model.dataset import exrio
    g = exrio.read_sample(tmp_path / "passes" / "000001.exr",
                          groups=("albedo", "normal", "depth", "direct", "eevee"))
    want, world = expected_image(FIX / "ssgi_tiny.pt", g, 100.0)  # 100: the room camera's clip end (room.py)
    got = read_rgba(tmp_path / "frame.exr")
    assert got.shape[:2] == (9, 16)
    np.testing.assert_allclose(got[..., :3], want, rtol=1e-5, atol=1e-6)
    assert (~world).sum() > 20 and float(got[..., :3][~world].mean()) > 0
    assert hashlib.sha256(blend.read_bytes()).hexdigest() == sha  # the user's file is not written
