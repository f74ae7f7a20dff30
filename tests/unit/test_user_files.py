"""User files made by an older SSGI (tests/fixtures/, made by commit 4187f74 with make_fixtures.py) still load,
predict what they predicted then, verify, feed training and resume it. Their Blender side (cli.py verify, the
saved .blend rendering through its SSGI node) is tests/blender/test_user_files.py."""
from __future__ import annotations

import shutil

import numpy as np

from ssgi.model.dataset import exrio
from ssgi.model.dataset import folder as ds
from ssgi.model.infer import predictor
from ssgi.model.learn import checkpoint, data
from ssgi.model.learn.train import TrainConfig, Trainer

from ..conftest import ROOT

FIX = ROOT / "tests" / "fixtures"


def test_old_checkpoint_loads_and_predicts_what_it_predicted_then():
    ck = checkpoint.load(FIX / "ssgi_tiny.pt")
    assert ck["arch"]["variant"] == "unet_s" and ck["arch"]["widths"] == [4, 8, 8]
    assert ck["inputs"] == ["albedo", "normal", "depth", "direct", "lit"]
    got = predictor.load_predictor(FIX / "ssgi_tiny.pt", num_threads=1).predict(
        exrio.read_sample(FIX / "dataset" / "000000.exr"))
    planes, _ = exrio.read_exr(FIX / "predict_000000.exr")  # `cli.py predict` of the old code
    then = np.stack([planes[c] for c in "RGB"], -1)
    assert got.shape == then.shape == (9, 16, 3) and float(then.max()) > 0
    np.testing.assert_allclose(got, then, rtol=1e-3, atol=1e-4)  # the old file held 16-bit floats


def test_old_dataset_verifies_and_loads(tmp_path):
    d = shutil.copytree(FIX / "dataset", tmp_path / "dataset")
    assert ds.verify(d) == []
    m = ds.open_folder(d)
    assert m["settings"]["size"] == [16, 9] and sorted(m["samples"]) == ["000000", "000001"]
    folder = data.DatasetFolder.load(d)
    assert len(folder.samples) == 2 and not folder.skipped
    assert all(tuple(s.y.shape) == (3, 9, 16) and bool(np.isfinite(s.x.numpy()).all()) for s in folder.samples)


def test_old_training_resumes_for_one_more_epoch(tmp_path):
    d = shutil.copytree(FIX / "dataset", tmp_path / "dataset")
    for f in ("ssgi_tiny.pt", "ssgi_tiny.last.pt"):
        shutil.copy(FIX / f, tmp_path / f)
    old = checkpoint.load(FIX / "ssgi_tiny.last.pt")
    assert old["train_state"]["epoch"] == 1
    cfg = TrainConfig(data=str(d), out=str(tmp_path / "ssgi_tiny.pt"), resume=True, epochs=2, threads=1, command="test")
    logs = []
    Trainer(cfg, log=logs.append).run()
    assert any("resuming from" in m and "at epoch 1" in m for m in logs), logs
    last = checkpoint.load(tmp_path / "ssgi_tiny.last.pt")
    assert last["train_state"]["epoch"] == 2 and last["arch"]["widths"] == [4, 8, 8]
    assert last["history"][0] == old["history"][0] and len(last["history"]) == 2
