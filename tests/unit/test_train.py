"""model/: dataset folder, trainer (resume, cancel, NaN guard), linear baseline and the train/predict CLI."""
import json
import math

import numpy as np
import pytest
import torch

from ssgi.model import channels as ch
from ssgi.model.learn import checkpoint, data, network
from ssgi.model.infer import predictor
from ssgi.model.dataset import exrio, synthetic
from ssgi.model.dataset import folder as ds_mod
from ssgi.model.learn.baseline import fit, run_baseline
from ssgi.model.errors import UserError
from ssgi.model.learn.train import Diverged, TrainConfig, Trainer


@pytest.fixture(scope="module")
def dataset_dir(tmp_path_factory):
    return synthetic.make_dataset(tmp_path_factory.mktemp("syn"), scenes=5, per_scene=2, w=40, h=24, seed=7)


def _cfg(dataset_dir, out, **kw):
    base = dict(data=str(dataset_dir), out=str(out), variant="unet_s", inputs=ch.format_spec(ch.DEFAULT_INPUTS), epochs=3, crop=16, batch=4,
                crops_per_image=2, seed=1, command="test")
    base.update(kw)
    return TrainConfig(**base)


def _log(msgs):
    return msgs.append


# ---------------------------------------------------------------- dataset

def test_dataset_loads_and_splits_by_scene(dataset_dir):
    ds = data.DatasetFolder.load(dataset_dir)
    assert len(ds) == 10 and len(ds.scenes) == 5
    x, y = ds[0]
    assert x.shape == (13, 24, 40) and y.shape == (3, 24, 40) and torch.isfinite(x).all()
    tr, va = data.split_scenes(ds.scenes, 0.2, seed=0)
    assert set(tr).isdisjoint(va) and sorted(tr + va) == ds.scenes and len(va) == 1
    assert data.split_scenes(ds.scenes, 0.2, seed=0) == (tr, va)  # deterministic
    assert {s.scene for s in ds.subset(va)} == set(va)


def test_dataset_errors_name_the_file(tmp_path, dataset_dir):
    d = synthetic.make_dataset(tmp_path / "d", scenes=2, per_scene=1, w=8, h=8)
    m = json.loads((d / "manifest.json").read_text())
    m["format_version"] = ch.FORMAT_VERSION + 1
    (d / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(UserError, match=r"manifest.json: manifest format_version \d+ is newer"):
        data.DatasetFolder.load(d)
    # one reader of the format (model/dataset/folder.open_folder) serves training, the baker and verify alike
    for bad, says in ((ch.FORMAT_VERSION - 1, rf"format_version {ch.FORMAT_VERSION - 1} is older than "
                       rf"{ch.FORMAT_VERSION}; re-bake"), ("3", r"has no integer 'format_version' \('3'\)"),
                      (True, r"has no integer 'format_version' \(True\)")):
        (d / "manifest.json").write_text(json.dumps(dict(m, format_version=bad)))
        for read in (lambda root: ds_mod.open_folder(root, scenes=True), ds_mod.open_folder):
            with pytest.raises(UserError, match=r"manifest.json: manifest " + says):
                read(d)
    (d / "manifest.json").write_text(json.dumps(dict(m, format_version=ch.FORMAT_VERSION, samples=[])))
    with pytest.raises(UserError, match=r"manifest.json: not an SSGI dataset manifest .*no 'samples' table"):
        ds_mod.open_folder(d, scenes=True)
    (d / "manifest.json").write_text(json.dumps(dict(m, format_version=ch.FORMAT_VERSION,
                                                     samples={"000000": {"seed": 1}})))
    with pytest.raises(UserError, match=r"manifest.json: sample '000000' has no 'scene' id"):
        ds_mod.open_folder(d, scenes=True)
    m["format_version"] = ch.FORMAT_VERSION
    (d / "manifest.json").write_text(json.dumps(m))
    (d / "000001.exr").unlink()
    with pytest.raises(UserError, match=r"000001\.exr: listed in the manifest but missing"):
        data.DatasetFolder.load(d)
    with pytest.raises(UserError, match="no manifest.json"):
        data.DatasetFolder.load(tmp_path)


def test_nan_reference_sample_is_left_out(tmp_path):
    d = synthetic.make_dataset(tmp_path / "d", scenes=2, per_scene=2, w=8, h=8)
    g = exrio.read_sample(d / "000002.exr")
    g["ref"][1, 1, 0] = np.nan
    exrio.write_sample(d / "000002.exr", g)
    ds = data.DatasetFolder.load(d)
    assert len(ds) == 3 and "000002" in ds.skipped and "non-finite" in ds.skipped["000002"]


# ---------------------------------------------------------------- trainer

def test_training_learns_and_writes_checkpoints(tmp_path, dataset_dir):
    out = tmp_path / "m.pt"
    events = []
    res = Trainer(_cfg(dataset_dir, out, epochs=4, crops_per_image=4, lr=3e-3), log=_log([])).run(callback=events.append)
    assert res["status"] == "done" and res["epochs"] == 4
    ck = checkpoint.load(out)
    hist = checkpoint.load(checkpoint.last_path(out))["history"]
    assert [h["epoch"] for h in hist] == [1, 2, 3, 4]
    assert ck["history"] == hist[:ck["best"]["epoch"]]  # MODEL is the best epoch's state
    assert hist[-1]["loss"] < hist[0]["loss"]
    assert max(h["val_psnr"] for h in hist) > hist[0]["val_psnr"]
    assert ck["best"]["val_psnr"] == max(h["val_psnr"] for h in hist)
    assert ck["dataset"]["split"]["val"] and set(ck["dataset"]["split"]["val"]).isdisjoint(ck["dataset"]["split"]["train"])
    assert ck["dataset"]["manifest_sha256"] == ds_mod.manifest_sha256(dataset_dir)
    assert ck["command"] == "test" and ck["arch"]["variant"] == "unet_s" and ck["inputs"] == list(ch.DEFAULT_INPUTS)
    assert "train_state" not in ck and "train_state" in checkpoint.load(checkpoint.last_path(out))
    assert checkpoint.curve_path(out).stat().st_size > 1000
    ep = [e for e in events if e["event"] == "epoch"]
    assert len(ep) == 4 and all({"epoch", "loss", "val_psnr", "eta_s", "progress"} <= set(e) for e in ep)
    assert ep[-1]["progress"] == 1.0
    # the best checkpoint predicts like the network did at its best epoch
    pred = predictor.load_predictor(out)
    s = data.DatasetFolder.load(dataset_dir).subset(ck["dataset"]["split"]["val"])[0]
    g = exrio.read_sample(dataset_dir / f"{s.key}.exr")
    assert np.isfinite(pred.predict(g)).all()


def test_resume_equals_uninterrupted_and_cancel_stops_within_a_batch(tmp_path, dataset_dir):
    a = tmp_path / "a.pt"
    Trainer(_cfg(dataset_dir, a), log=_log([])).run()
    b = tmp_path / "b.pt"
    calls = [0]

    def stop():  # 4 batches an epoch: cancel before the 2nd batch of epoch 2
        calls[0] += 1
        return calls[0] >= 6

    t = Trainer(_cfg(dataset_dir, b), log=_log([]))
    res = t.run(should_stop=stop)
    assert res["status"] == "cancelled" and res["step"] == 5  # no batch after the request
    assert checkpoint.load(checkpoint.last_path(b))["train_state"]["step"] == 4
    res = Trainer(_cfg(dataset_dir, b, resume=True), log=_log([])).run()
    assert res["status"] == "done" and res["step"] == 12
    ca, cb = checkpoint.load(checkpoint.last_path(a)), checkpoint.load(checkpoint.last_path(b))
    for k, v in ca["state_dict"].items():
        assert torch.equal(v, cb["state_dict"][k]), k
    assert [h["val_psnr"] for h in ca["history"]] == [h["val_psnr"] for h in cb["history"]]
    assert [h["step"] for h in cb["history"]] == [4, 8, 12]


def test_huge_learning_rate_is_caught_and_last_good_checkpoint_kept(tmp_path, dataset_dir):
    out = tmp_path / "m.pt"
    Trainer(_cfg(dataset_dir, out, epochs=1), log=_log([])).run()
    before = out.read_bytes()
    msgs = []
    try:
        res = Trainer(_cfg(dataset_dir, out, epochs=3, lr=10.0, resume=True), log=_log(msgs)).run()
    except Diverged as e:
        assert "diverged" in str(e) and str(out) in str(e)
        assert out.read_bytes() == before
    else:  # recovered: bad steps were caught and the learning rate lowered
        assert res["skipped_steps"] > 0
        assert any("step skipped" in m for m in msgs)
    for p in (out, checkpoint.last_path(out)):
        sd = checkpoint.load(p)["state_dict"]
        assert all(torch.isfinite(v).all() for v in sd.values())


def test_poisoned_nan_sample_is_detected_and_left_out(tmp_path, dataset_dir):
    ds = data.DatasetFolder.load(dataset_dir)
    tr, _ = data.split_scenes(ds.scenes, 0.2, 1)
    victim = ds.subset(tr)[0]
    victim.y[1].fill_(float("nan"))  # bypasses the loader's check, as a broken sample in memory would
    msgs = []
    res = Trainer(_cfg(dataset_dir, tmp_path / "m.pt", epochs=2), dataset=ds, log=_log(msgs)).run()
    assert res["status"] == "done"
    assert any(victim.key in m and "left out" in m for m in msgs)
    sd = checkpoint.load(tmp_path / "m.pt")["state_dict"]
    assert all(torch.isfinite(v).all() for v in sd.values())


def test_constant_dataset_trains_without_nan(tmp_path):
    d = synthetic.make_dataset(tmp_path / "d", scenes=2, per_scene=2, w=16, h=16)
    for f in d.glob("*.exr"):
        g = exrio.read_sample(f)
        exrio.write_sample(f, {k: np.full_like(v, 0.5) for k, v in g.items()})
    res = Trainer(_cfg(d, tmp_path / "m.pt", epochs=2), log=_log([])).run()
    assert math.isfinite(res["best"]["val_psnr"]) or res["best"]["val_psnr"] == math.inf


# ---------------------------------------------------------------- baseline

def test_linear_fit_recovers_an_exact_linear_map():
    rng = np.random.default_rng(0)
    w, b = rng.normal(size=(13, 3)), rng.normal(size=3)
    samples = []
    for i in range(3):
        x = torch.from_numpy(rng.uniform(0, 1, (13, 6, 7)).astype(np.float32))
        y = torch.einsum("chw,cd->dhw", x.double(), torch.from_numpy(w)) + torch.from_numpy(b)[:, None, None]
        samples.append(data.Sample(str(i), "s", x, y.float()))
    wf, bf = fit(samples)
    np.testing.assert_allclose(wf, w, atol=1e-3)
    np.testing.assert_allclose(bf, b, atol=1e-3)


def test_baseline_checkpoint_predicts_like_a_model(tmp_path, dataset_dir):
    res = run_baseline(dataset_dir, tmp_path / "lin.pt", log=_log([]))
    pred = predictor.load_predictor(tmp_path / "lin.pt")
    assert pred.kind == "linear" and pred.arch["variant"] == "linear"
    g = exrio.read_sample(dataset_dir / "000000.exr")
    out = pred.predict(g)
    assert out.shape == g["ref"].shape and np.isfinite(out).all() and (out >= 0).all()
    assert res["best"]["val_psnr"] > 15  # it does explain the data: the synthetic ref is near-linear in lit


def test_background_pixels_are_left_out_of_metrics_and_loss(dataset_dir):
    """Where nothing was hit (zero normal) the world shows; the metrics and the baseline fit ignore it."""
    from ssgi.model.learn.validation import evaluate
    net = network.build(network.arch_for("linear", space="linear"))
    with torch.no_grad():
        net.conv.weight.zero_()
        net.conv.bias.fill_(0.25)
    x = torch.zeros(13, 6, 8)
    y = torch.full((3, 6, 8), 0.25)
    mask = torch.ones(6, 8, dtype=torch.bool)
    mask[:, :3] = False
    y[:, :, :3] = 7.0  # the world, bright: not the model's job
    s = data.Sample("k", "s", x, y, 0, mask)
    assert evaluate(net, [s])["val_psnr"] == math.inf
    assert evaluate(net, [data.Sample("k", "s", x, y)])["val_psnr"] < 10  # scored everywhere without a mask
    w, b = fit([s])
    np.testing.assert_allclose(b, [0.25] * 3, atol=1e-6)
    ds = data.DatasetFolder.load(dataset_dir)
    assert all(bool(s.mask.all()) for s in ds.samples)  # synthetic samples: geometry everywhere


def test_one_loader_serves_training_and_the_fit(dataset_dir):
    """DatasetFolder.load (training) and StoredSamples (the fit, many specs from one read) build the same
    samples bit for bit; keys select samples, and a key the manifest lacks is an error naming the manifest."""
    keys = ["000001", "000004"]
    spec = ch.parse_spec("albedo,normal,depth,direct,lit")
    a = data.DatasetFolder.load(dataset_dir, spec, keys=keys)
    b = data.StoredSamples(dataset_dir, keys).dataset(spec, keys)
    assert [s.key for s in a.samples] == [s.key for s in b.samples] == keys
    for s, t in zip(a.samples, b.samples):
        assert s.scene == t.scene and torch.equal(s.x, t.x) and torch.equal(s.y, t.y) and torch.equal(s.mask, t.mask)
    with pytest.raises(UserError, match=r"manifest\.json: lists no sample '999999'"):
        data.DatasetFolder.load(dataset_dir, spec, keys=["999999"])


# ---------------------------------------------------------------- defaults and retired variants

def test_train_without_options_trains_the_shipped_default_model(tmp_path):
    """`cli.py train --data D --out M` parses to the recipe of models/ssgi_default.json (the crop, batch and
    learning rate of its recipe's train command) and trains its network: variant, inputs, target, widths, convs, head and
    parameter count of its ``arch``."""
    import argparse

    from ssgi.model import shipped
    from ssgi.model.learn import config
    from ssgi.ssgi_addon.commands import train as train_command

    parser = argparse.ArgumentParser()
    train_command.register_cli(parser.add_subparsers())
    root = synthetic.make_dataset(tmp_path / "d", scenes=3, per_scene=1, w=40, h=24, shipped=True)
    args = parser.parse_args(["train", "--data", str(root), "--out", str(tmp_path / "m.pt")])
    desc = json.loads(shipped.DEFAULT.path.with_suffix(".json").read_text())
    train = desc["recipe"]["train"]
    recipe = {k: train[train.index(f"--{k}") + 1] for k in ("crop", "batch", "lr")}
    assert (args.crop, args.batch) == (int(recipe["crop"]), int(recipe["batch"]))
    assert args.lr is None and args.optimizer == "adam" and config.ADAM_LR == float(recipe["lr"])
    assert (args.variant, args.inputs, args.arch, args.target) == (TrainConfig.variant, TrainConfig.inputs, None,
                                                                   TrainConfig.target)
    Trainer(TrainConfig(data=str(root), out=args.out, epochs=1, threads=1, command="test"), log=lambda m: None).run()
    ck = checkpoint.load(args.out)
    for k in ("variant", "inputs", "target", "backbone", "widths", "convs", "head"):
        assert ck["arch"][k] == desc["arch"][k], k
    assert ck["params"] == desc["params"]


@pytest.mark.parametrize("variant", ["lean", "unet_l"])
def test_checkpoint_of_a_retired_variant_is_refused_in_one_line(tmp_path, variant):
    """A checkpoint whose variant this SSGI no longer has is a UserError that names it and what to use."""
    net = network.build(network.arch_for("unet_s"))
    ck = checkpoint.make(net, "model", command="test")
    ck["arch"] = dict(ck["arch"], variant=variant)
    path = tmp_path / "old.pt"
    torch.save(ck, path)
    with pytest.raises(UserError) as e:
        predictor.load_predictor(path, runtime="torch")
    msg = str(e.value)
    assert "\n" not in msg and f"variant {variant!r} is no longer supported" in msg and "unet_s" in msg, msg
