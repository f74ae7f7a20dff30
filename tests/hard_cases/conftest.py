"""Shared fixtures of the hard-case suite: a tiny synthetic dataset and two briefly trained models.

The models are trained for real (a few epochs on CPU, one thread) so that tests of precision, HDR and black
scenes run on weights that have learnt something, not only on random ones. One model of each head kind:
``unet_s`` (residual head: albedo x predicted shading) and a small ``fssgi`` (the seed's plain log head).
"""
from __future__ import annotations

import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from ssgi.model.dataset import synthetic
from ssgi.model.infer.bench import synthetic_groups
from ssgi.model.learn.train import TrainConfig, Trainer

from ..conftest import ROOT, clean

# variant name -> architecture overrides; "fssgi" is shrunk to keep the suite fast (same head and backbone)
MODELS = {"unet_s": {}, "fssgi": {"width": 16, "pre": 2, "post": 2}}


@pytest.fixture(scope="session")
def syn_data(tmp_path_factory):
    """A synthetic dataset folder: 4 scenes x 2 views of 48x32, float EXRs."""
    return synthetic.make_dataset(tmp_path_factory.mktemp("hard-syn") / "data", scenes=4, per_scene=2, w=48, h=32,
                                  seed=5)


def train_cfg(data, out, variant="unet_s", **kw) -> TrainConfig:
    base = dict(data=str(data), out=str(out), variant=variant, arch=dict(MODELS.get(variant, {})),
                inputs="albedo,normal,depth,direct,lit", epochs=3,
                crop=16, batch=4, crops_per_image=3, seed=0, lr=3e-3, threads=1, command="hard-cases")
    base.update(kw)
    return TrainConfig(**base)


@pytest.fixture(scope="session")
def trained(syn_data, tmp_path_factory):
    """{variant: checkpoint path} of briefly trained models (see MODELS)."""
    d = tmp_path_factory.mktemp("hard-models")
    out = {}
    for v in MODELS:
        out[v] = d / f"{v}.pt"
        Trainer(train_cfg(syn_data, out[v], v), log=lambda m: None).run()
    return out


def groups(w: int, h: int, seed: int = 0, light: float = 1.0) -> dict[str, np.ndarray]:
    """Plausible G-buffer groups (HxWxC float32) of size w x h; ``light`` scales the direct light."""
    g = synthetic_groups(w, h, seed)
    g["direct"] = (g["direct"] * np.float32(light)).astype(np.float32)
    return g


def kill_at_random(args: list[str], ready, seed: int, span: float, timeout: float = 800) -> float:
    """Start `cli.py ARGS`; once ``ready()`` is true, wait a delay drawn from random.Random(seed) in
    [0, span) seconds and SIGKILL it. Fails if it ended before the kill. Returns the delay."""
    delay = random.Random(seed).uniform(0.0, span)
    p = subprocess.Popen([sys.executable, str(ROOT / "cli.py"), *args], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, cwd=ROOT)
    try:
        t0 = time.monotonic()
        while not ready():
            assert p.poll() is None, clean(p.stderr.read().decode(errors="replace"))[-3000:]
            assert time.monotonic() - t0 < timeout, "the job never got going"
            time.sleep(0.02)
        time.sleep(delay)
        assert p.poll() is None, "the job ended before the kill: make it longer"
        p.send_signal(signal.SIGKILL)
        p.wait(30)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
        p.stderr.close()
    assert p.returncode == -signal.SIGKILL
    return delay
