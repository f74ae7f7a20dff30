"""Several dataset folders train together (`cli.py train --data A B`): each folder keeps its own split, the
checkpoint records every folder, resume checks them all, and the report finds a folder's validation scenes."""
import pytest

from ssgi.model.dataset import synthetic
from ssgi.model.errors import UserError
from ssgi.model.learn import checkpoint, data
from ssgi.model.learn.train import TrainConfig, Trainer


def test_two_folders_train_together_each_split_as_alone_and_resume_checks_both(tmp_path):
    a = synthetic.make_dataset(tmp_path / "artist", scenes=5, per_scene=1, w=24, h=16, seed=1, emission=True)
    b = synthetic.make_dataset(tmp_path / "studio", scenes=4, per_scene=2, w=24, h=16, seed=2, emission=True)
    fs = data.load_folders([str(a), str(b)], "albedo,normal,depth,direct,emission")
    alone = [data.DatasetFolder.load(r, "albedo,normal,depth,direct,emission") for r in (a, b)]
    assert len(fs) == len(alone[0]) + len(alone[1]) == 13 and fs.target == "ref_diffuse"
    assert {s.key for s in fs.samples} >= {"artist/000000", "studio/000000"}  # keys of both, kept apart
    tr, va = fs.split(0.2, 0)
    want_val = [f"artist/{s}" for s in alone[0].split(0.2, 0)[1]] + [f"studio/{s}" for s in alone[1].split(0.2, 0)[1]]
    assert va == sorted(want_val) and set(tr).isdisjoint(va) and len(tr) + len(va) == 9
    # the same samples as loading each folder alone
    x0 = next(s.x for s in fs.samples if s.key == "studio/000003")
    assert (x0 == next(s.x for s in alone[1].samples if s.key == "000003")).all()

    out = tmp_path / "m.pt"
    cfg = dict(data=[str(a), str(b)], out=str(out), variant="unet_s", inputs="albedo,normal,depth,direct,emission",
               epochs=1, crop=16, batch=2, crops_per_image=1, command="test")
    Trainer(TrainConfig(**cfg)).run()
    ck = checkpoint.load(out)
    ident = ck["dataset"]
    assert ident["tags"] == ["artist", "studio"] and len(ident["folders"]) == 2
    assert ident["split"]["val"] == sorted(want_val)
    # the report asks a record for one folder's split: prefixes off, that folder's scenes only
    rec = data.recorded_split(ident, ident["folders"][1]["manifest_sha256"], None)
    assert rec["val"] == alone[1].split(0.2, 0)[1] and rec["train"] == alone[1].split(0.2, 0)[0]
    assert data.recorded_split(ident, "no-such-sha", "/nowhere") is None
    assert sorted(data.recorded_split(ident)["train"]) == sorted(s.split("/", 1)[1] for s in tr)

    # resume with the folders in another order is another dataset: refused, the checkpoint untouched
    before = checkpoint.last_path(out).read_bytes()
    with pytest.raises(UserError, match=r"trained on another dataset .*studio.*artist"):
        Trainer(TrainConfig(**dict(cfg, data=[str(b), str(a)], resume=True, epochs=2))).run()
    assert checkpoint.last_path(out).read_bytes() == before
    Trainer(TrainConfig(**dict(cfg, resume=True, epochs=2))).run()
    assert checkpoint.load(checkpoint.last_path(out))["train_state"]["epoch"] == 2


def test_bad_folder_lists_are_refused_with_the_folder_named(tmp_path):
    a = synthetic.make_dataset(tmp_path / "x" / "d", scenes=2, per_scene=1, w=8, h=8, seed=1)
    b = synthetic.make_dataset(tmp_path / "y" / "d", scenes=2, per_scene=1, w=8, h=8, seed=2)
    fs = data.load_folders([a, b], "albedo,normal,depth,direct")  # same names: the parents tell them apart
    assert fs.tags == ["x.d", "y.d"] and fs.target == "ref"
    with pytest.raises(UserError, match="the same folder is given twice"):
        data.load_folders([a, a], "albedo,normal,depth,direct")
    with pytest.raises(UserError, match="nowhere: dataset folder does not exist"):
        data.load_folders([a, tmp_path / "nowhere"], "albedo,normal,depth,direct")
    # a folder without the diffuse part makes the set learn the whole image; asking for the part names it
    c = synthetic.make_dataset(tmp_path / "c", scenes=2, per_scene=1, w=8, h=8, seed=3, emission=True)
    assert data.load_folders([a, c], "albedo,normal,depth,direct").target == "ref"
    with pytest.raises(UserError, match=r"x/d/manifest.json: this dataset was baked without the group\(s\) ref_diffuse"):
        data.load_folders([a, c], "albedo,normal,depth,direct", target="ref_diffuse")


def test_validation_scores_each_folder_and_keeps_the_best_by_their_mean(tmp_path):
    import math

    import numpy as np
    import torch

    from ssgi.model.learn import network, validation

    a = synthetic.make_dataset(tmp_path / "big", scenes=6, per_scene=1, w=24, h=16, seed=1, emission=True)
    b = synthetic.make_dataset(tmp_path / "small", scenes=2, per_scene=1, w=24, h=16, seed=2, emission=True)
    spec = "albedo,normal,depth,direct,emission"
    fs = data.load_folders([str(a), str(b)], spec)
    torch.manual_seed(0)
    net = network.build(network.arch_for("unet_s", spec))
    ev = validation.evaluate(net, fs.samples, with_ssim=False)
    # each folder's own pooled PSNR, as scoring that folder alone gives; the score is their plain mean
    for tag in ("big", "small"):
        alone = validation.evaluate(net, [s for s in fs.samples if s.key.startswith(tag + "/")], with_ssim=False)
        assert math.isclose(ev["val_folders"][tag], alone["val_psnr"], rel_tol=1e-9)
        assert "val_folders" not in alone and alone["val_score"] == alone["val_psnr"]
    assert math.isclose(ev["val_score"], np.mean(list(ev["val_folders"].values())), rel_tol=1e-12)
    # pooled, the big folder weighs 3x: the pooled PSNR lies nearer its score than the mean does
    big, small = ev["val_folders"]["big"], ev["val_folders"]["small"]
    assert abs(ev["val_psnr"] - big) < abs(ev["val_score"] - big) or math.isclose(big, small, abs_tol=1e-6)

    out = tmp_path / "m.pt"
    from ssgi.model.learn.train import TrainConfig, Trainer
    Trainer(TrainConfig(data=[str(a), str(b)], out=str(out), variant="unet_s", inputs=spec, epochs=2, crop=16,
                        batch=2, crops_per_image=1, command="test")).run()
    ck = checkpoint.load(checkpoint.last_path(out))
    hist = ck["history"]
    assert all("val_folders" in h and set(h["val_folders"]) == {"big", "small"} for h in hist)
    assert ck["best"]["val_score"] == max(h["val_score"] for h in hist)
