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
