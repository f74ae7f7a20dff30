"""Hard cases 4 (constant datasets), 7 (divergent training), 9 (a killed training resumes) and 10 (training
is deterministic), on tiny synthetic datasets, CPU, one torch thread."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from ssgi.model.learn import checkpoint, data
from ssgi.model.dataset import exrio, synthetic
from ssgi.model.learn.train import Diverged, Trainer

from ..conftest import run_cli
from .conftest import kill_at_random, train_cfg


def _finite_weights(path: Path) -> bool:
    return all(torch.isfinite(v).all() for v in checkpoint.load(path)["state_dict"].values() if v.is_floating_point())


def _seeded_copy(src: Path, dst: Path, epochs: int = 1, **kw) -> Path:
    """A trained model at ``dst`` (and its .last.pt) to continue from."""
    Trainer(train_cfg(src, dst, epochs=epochs, **kw), log=lambda m: None).run()
    return dst


# ------------------------------------------------------------------------------------------- case 7

def test_learning_rate_10_from_scratch_is_detected_and_recovers(syn_data, tmp_path):
    """Case 7: Adam with a learning rate of 10 from the first step: the exploding steps are detected and
    skipped, the learning rate is halved back to sane, and the run ends with finite weights and a model that
    has learnt (validation PSNR >= 20 dB; the same run at lr 3e-3 reaches ~27 dB)."""
    msgs: list[str] = []
    out = tmp_path / "m.pt"
    res = Trainer(train_cfg(syn_data, out, epochs=4, lr=10.0), log=msgs.append).run()
    assert res["status"] == "done"
    assert res["skipped_steps"] > 0 and res["lr_drops"] >= 1
    assert any("learning rate halved" in m for m in msgs) and any("step skipped" in m for m in msgs)
    for p in (out, checkpoint.last_path(out)):
        assert _finite_weights(p), p
    assert res["best"]["val_psnr"] >= 20.0, res["best"]


def test_learning_rate_10_on_resume_keeps_the_last_good_checkpoint(syn_data, tmp_path):
    """Case 7: a good model trained 1 epoch, resumed with a learning rate of 10: bad steps are detected and the
    learning rate halved; no epoch beats the good model, so MODEL keeps its bytes; every weight saved is
    finite."""
    out = _seeded_copy(syn_data, tmp_path / "m.pt")
    before = out.read_bytes()
    good = checkpoint.load(out)["best"]["val_psnr"]
    msgs: list[str] = []
    res = Trainer(train_cfg(syn_data, out, epochs=4, lr=10.0, resume=True), log=msgs.append).run()
    assert res["lr_drops"] >= 1 and res["skipped_steps"] > 0
    assert res["best"]["epoch"] == 1 and res["best"]["val_psnr"] == good
    assert out.read_bytes() == before
    assert _finite_weights(checkpoint.last_path(out))


def test_hopeless_learning_rate_stops_with_a_clear_message(syn_data, tmp_path):
    """Case 7: with a learning rate of 1e6 halving cannot rescue the run: `cli.py train` stops with exit 2 and
    a message that says it diverged and names the kept checkpoint; no traceback; MODEL and MODEL.last.pt keep
    their bytes and no temporary file is left."""
    out = _seeded_copy(syn_data, tmp_path / "m.pt")
    last = checkpoint.last_path(out)
    before = (out.read_bytes(), last.read_bytes())
    p = run_cli("train", "--data", str(syn_data), "--out", str(out), "--resume", "--epochs", "3", "--lr", "1e6",
                "--threads", "1", "--quiet", check=False)
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr[-3000:]
    # either guard may fire first: the step guard ("training diverged ... after halving the learning rate") or
    # the validation guard ("validation loss is not finite"); both stop and name the kept model
    assert ("training diverged" in p.stderr or "validation loss is not finite" in p.stderr), p.stderr[-2000:]
    assert f"{out} is kept" in p.stderr
    assert (out.read_bytes(), last.read_bytes()) == before
    assert sorted(f.name for f in tmp_path.iterdir()) == ["m.curve.png", "m.last.pt", "m.pt"]


def test_poisoned_batch_with_one_nan_sample_is_left_out(syn_data, tmp_path):
    """Case 7: one training sample whose INPUT holds a NaN (in memory, past the loader's repair, as a broken
    sample would be) poisons its batch: the step is skipped, that sample is named and left out, the others
    keep training, and the saved weights are finite."""
    ds = data.DatasetFolder.load(syn_data)
    tr, _ = data.split_scenes(ds.scenes, 0.2, 0)
    victim = ds.subset(tr)[1]
    victim.x[2, 5:9, 5:9] = float("nan")
    msgs: list[str] = []
    out = tmp_path / "m.pt"
    res = Trainer(train_cfg(syn_data, out, epochs=2), dataset=ds, log=msgs.append).run()
    assert res["status"] == "done" and res["left_out"] == [victim.key]
    assert any(f"sample {victim.key}" in m and "left out" in m for m in msgs)
    assert res["step"] > 0 and math.isfinite(res["best"]["val_psnr"])
    assert _finite_weights(out) and _finite_weights(checkpoint.last_path(out))


def test_poisoned_files_are_skipped_or_repaired_by_the_cli(syn_data, tmp_path):
    """Case 7: on disk, a sample whose reference holds NaN is skipped (named, with its pixel count) and a
    sample whose inputs hold NaN/Inf is repaired (the count logged); `cli.py train` finishes with finite
    weights."""
    d = Path(shutil.copytree(syn_data, tmp_path / "d"))
    g = exrio.read_sample(d / "000001.exr")
    g["ref"][3, 4, 1] = np.nan
    exrio.write_sample(d / "000001.exr", g, half=False)
    g = exrio.read_sample(d / "000002.exr")
    g["direct"][0, 0, 0] = np.inf
    g["depth"][1, 1, 0] = np.nan
    exrio.write_sample(d / "000002.exr", g, half=False)
    out = tmp_path / "m.pt"
    p = run_cli("train", "--data", str(d), "--out", str(out), "--variant", "unet_s", "--inputs", "albedo,normal,depth,direct,lit", "--epochs", "1", "--crop",
                "16", "--threads", "1", "--quiet", "--json")
    assert "skipped sample 000001: 1 non-finite reference pixel(s)" in p.stderr
    assert "repaired 2 non-finite input pixel(s)" in p.stderr
    assert json.loads(p.stdout)["ok"] and _finite_weights(out)
    assert checkpoint.load(out)["dataset"]["skipped"] == {"000001": "1 non-finite reference pixel(s)"}


# ------------------------------------------------------------------------------------------- case 4

def _constant_dataset(root: Path, kind: str) -> Path:
    d = synthetic.make_dataset(root, scenes=2, per_scene=2, w=16, h=16)
    for f in sorted(d.glob("*.exr")):
        g = exrio.read_sample(f)
        if kind == "black":  # geometry everywhere, no light, black albedo, black reference
            g = {k: np.zeros_like(v) for k, v in g.items()}
            g["depth"][:] = 3.0
            g["normal"][..., 2] = 1.0
        else:  # every channel of every group the same constant
            g = {k: np.full_like(v, float(kind)) for k, v in g.items()}
        exrio.write_sample(f, g)
    return d


@pytest.mark.parametrize("kind", ["black", "0.5", "7.0"])
def test_constant_dataset_trains_without_nan(kind, tmp_path):
    """Case 4: datasets of constant images (all black with geometry; every channel 0.5; every channel 7)
    train 2 epochs with finite losses, finite weights and a finite (or, for a perfect fit, infinite)
    validation PSNR; none of the steps is skipped as non-finite."""
    d = _constant_dataset(tmp_path / "d", kind)
    out = tmp_path / "m.pt"
    res = Trainer(train_cfg(d, out, epochs=2, crop=8), log=lambda m: None).run()
    assert res["status"] == "done" and res["skipped_steps"] == 0
    hist = checkpoint.load(checkpoint.last_path(out))["history"]
    assert len(hist) == 2
    for h in hist:
        assert math.isfinite(h["loss"]) and math.isfinite(h["val_loss"]), h
        assert not math.isnan(h["val_psnr"]) and not math.isnan(h["val_tm_psnr"]), h
    assert _finite_weights(out)
    if kind == "black":
        assert hist[-1]["val_psnr"] == math.inf  # black albedo: the residual head predicts exactly 0


# ------------------------------------------------------------------------------------------- cases 9, 10

EPOCHS = 40  # ~50 ms each on an idle machine: a kill up to 1 s after epoch 1 lands mid-run
TRAIN = ("--variant", "unet_s", "--inputs", "albedo,normal,depth,direct,lit", "--epochs", str(EPOCHS), "--crop", "16", "--batch", "4", "--crops-per-image", "3",
         "--lr", "3e-3", "--seed", "3", "--threads", "1", "--quiet")


def _state(path: Path) -> tuple[dict, list]:
    ck = checkpoint.load(path)
    hist = [{k: h[k] for k in ("epoch", "step", "loss", "val_psnr", "val_tm_psnr", "val_ssim", "val_loss", "lr")}
            for h in ck["history"]]
    return ck["state_dict"], hist


def test_killed_training_resumes_to_the_same_state_and_is_deterministic(syn_data, tmp_path):
    """Cases 9 and 10: `cli.py train` run twice with the same seed gives the same weights and history (the
    same trajectory); killed with SIGKILL at a seeded random moment after its first epoch, then rerun with
    --resume, it ends at the same step with the same weights and metrics as the uninterrupted run, and no
    temporary file is left beside the model, even one that a kill during a checkpoint write left behind."""
    a, c = tmp_path / "a" / "m.pt", tmp_path / "c" / "m.pt"
    run_cli("train", "--data", str(syn_data), "--out", str(a), *TRAIN)
    run_cli("train", "--data", str(syn_data), "--out", str(c), *TRAIN)
    sa, ha = _state(checkpoint.last_path(a))
    sc, hc = _state(checkpoint.last_path(c))
    assert ha == hc and len(ha) == EPOCHS
    assert all(torch.equal(v, sc[k]) for k, v in sa.items())

    b = tmp_path / "b" / "m.pt"
    delay = kill_at_random(["train", "--data", str(syn_data), "--out", str(b), *TRAIN],
                           lambda: checkpoint.last_path(b).is_file(), seed=9, span=1.0)
    done = checkpoint.load(checkpoint.last_path(b))["train_state"]["epoch"]
    assert 1 <= done < EPOCHS, done
    # a kill in the middle of a checkpoint write leaves its temporary file (dead writer's pid in the name)
    for stale in (f".{b.name}.999999.tmp", f".{checkpoint.last_path(b).name}.999999.tmp"):
        (b.parent / stale).write_bytes(b"half a checkpoint")
    p = run_cli("train", "--data", str(syn_data), "--out", str(b), *TRAIN, "--resume")
    assert f"at epoch {done}" in p.stderr
    sb, hb = _state(checkpoint.last_path(b))
    assert hb == ha, (delay, done)
    assert all(torch.equal(v, sb[k]) for k, v in sa.items())
    assert checkpoint.load(b)["best"]["epoch"] == checkpoint.load(a)["best"]["epoch"]
    assert sorted(f.name for f in b.parent.iterdir()) == ["m.curve.png", "m.last.pt", "m.pt"]
