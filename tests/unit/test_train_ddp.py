"""The trainer's process setup and data loading, bpy-free: a launch without torchrun's environment, the device
choice, the memory-bounded sample cache and loader workers. The torchrun runs (cli.py needs bpy) are
tests/blender/test_train_torchrun.py."""
import pytest
import torch

from ssgi.model.dataset import synthetic
from ssgi.model.errors import UserError
from ssgi.model.learn import batches, checkpoint, data, distributed
from ssgi.model.learn.train import TrainConfig, Trainer


@pytest.fixture(scope="module")
def ds(tmp_path_factory):
    return synthetic.make_dataset(tmp_path_factory.mktemp("syn"), scenes=5, per_scene=2, w=40, h=24, seed=7)


def _cfg(ds, out, epochs, **kw):
    return TrainConfig(data=str(ds), out=str(out), variant="unet_s", inputs="albedo,normal,depth,direct,lit", epochs=epochs, crop=16, batch=4,
                       crops_per_image=2, seed=1, threads=1, command="test", **kw)


def _last(out):
    return checkpoint.load(checkpoint.last_path(out))


def _max_diff(a, b):
    return max(float((a["state_dict"][k] - b["state_dict"][k]).abs().max()) for k in a["state_dict"])


def test_a_launch_without_torchrun_environment_is_refused(monkeypatch, tmp_path, ds):
    monkeypatch.setenv("WORLD_SIZE", "2")
    monkeypatch.delenv("MASTER_ADDR", raising=False)
    with pytest.raises(UserError, match="WORLD_SIZE=2 but RANK.*torchrun"):
        Trainer(_cfg(ds, tmp_path / "m.pt", 1), log=lambda m: None).run()
    assert not (tmp_path / "m.pt").exists()


def test_sample_cache_is_bounded_and_workers_and_cache_train_like_memory(tmp_path, ds):
    mem = tmp_path / "mem.pt"
    Trainer(_cfg(ds, mem, 2), log=lambda m: None).run()
    lazy = tmp_path / "lazy.pt"
    one = batches.SampleCache.nbytes(data.DatasetFolder.load(ds, keys=["000000"]).samples[0])
    t = Trainer(_cfg(ds, lazy, 2, cache_mb=1.5 * one / 2 ** 20, workers=2), log=lambda m: None)
    t.run()
    assert _max_diff(_last(mem), _last(lazy)) == 0.0  # the same crops of the same samples
    cache = t.dataset.samples[0].cache  # this process's (validation reads); the workers hold their own
    assert cache.bytes <= cache.max_bytes and len(cache.items) == 1 and cache.reads == 4  # 2 val samples x 2 epochs
    assert isinstance(t.dataset.samples[0], batches.LazySample)
    with pytest.raises(UserError, match="--cache-mb must be > 0"):
        _cfg(ds, lazy, 1, cache_mb=0).check()


def test_device_choice():
    assert distributed.pick_device("cpu").type == "cpu"
    if not torch.cuda.is_available():
        assert distributed.pick_device("auto").type == "cpu"
        with pytest.raises(UserError, match="--device cuda: torch sees no CUDA device"):
            distributed.pick_device("cuda")


def test_the_plan_is_one_for_every_process_count_and_the_shares_partition_it():
    import torch as t
    sizes = [(24, 40)] * 5 + [(30, 20)] * 3
    a = batches.plan(t.Generator().manual_seed(3), sizes, 2, 5, (16, 16))
    b = batches.plan(t.Generator().manual_seed(3), sizes, 2, 5, (16, 16))
    assert a == b and len(a) == 4 and sum(map(len, a)) == 16 and sorted(s[0] for g in a for s in g) == sorted(list(range(8)) * 2)
    assert all(0 <= y0 <= sizes[i][0] - 16 and 0 <= x0 <= sizes[i][1] - 16 for g in a for i, y0, x0, _ in g)
    for w in (1, 2, 3):
        shares = [batches.share(a, r, w) for r in range(w)]
        for k, g in enumerate(a):  # every crop of a global batch goes to exactly one rank, in order
            assert sorted(c for r in range(w) for c in shares[r][k]) == sorted(g)
    assert batches.share(a, 1, 2)[-1] == a[-1][1::2]


def test_a_backend_error_is_cut_to_its_gist():
    e = RuntimeError("[/__w/pytorch/pytorch/third_party/gloo/gloo/transport/tcp/pair.cc:537] Read error "
                     "[127.0.0.1]:38296: Connection reset by peer. This is typically caused by a remote worker hanging")
    assert distributed._first_sentence(e) == "Read error [127.0.0.1]:38296: Connection reset by peer"
    d = distributed.Dist(rank=1, world=2, note=" The last good checkpoint m.last.pt is kept.")
    with pytest.raises(distributed.LostRank, match=r"^rank 1 of 2: lost contact .* during x \(another rank died or "
                                                   r"hung: Read error .*peer\); stopped\. The last good checkpoint"):
        d._fail("x", e)

