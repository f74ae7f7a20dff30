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
    return TrainConfig(data=str(ds), out=str(out), variant="unet_s", epochs=epochs, crop=16, batch=4,
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
