"""The training settings (torch-free, so that the Blender UI and argparse read their defaults without torch).

``TrainConfig`` is what ``cli.py train``, the Train panel and ``model.learn.train.Trainer`` share; its field
defaults are the defaults of all three, and they are the recipe of the shipped default model
(models/ssgi_default.json: variant, inputs, target, crop, batch, learning rate). ``minutes`` None with
``epochs`` None trains ``DEFAULT_MINUTES``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .. import channels as ch
from ..errors import UserError
from . import variants

DEFAULT_MINUTES = 10.0
# the input groups of the shipped default model
SHIPPED_INPUTS = ("albedo", "normal", "depth", "direct", "direct_soft", "lit", "scene", "world", "emission",
                  "emit_direct", "glow", "surround")
ADAM_LR, SGD_LR = 5e-4, 1e-2  # the learning rate when none is given


def data_dirs(data) -> list[str]:
    """``TrainConfig.data`` as a list of folders (it is one folder, or a list: ``cli.py train --data A B``)."""
    return [str(data)] if isinstance(data, (str, bytes)) or not hasattr(data, "__iter__") else [str(d) for d in data]


@dataclass
class TrainConfig:
    data: str | list  # a dataset folder, or several that train together (data.load_folders)
    out: str
    variant: str = variants.DEFAULT
    inputs: str = ch.format_spec(SHIPPED_INPUTS)
    arch: dict = field(default_factory=dict)  # overrides of the variant's settings, e.g. {"width": 32}
    minutes: float | None = None
    epochs: int | None = None
    resume: bool = False
    optimizer: str = "adam"
    lr: float | None = None  # None: ADAM_LR with adam, SGD_LR with sgd
    clip: float | None = None
    batch: int = 8
    crop: int = 128
    crops_per_image: int | None = None
    early_stop: int | None = None
    threads: int | None = None
    seed: int = 0
    val_fraction: float = 0.2
    target: str | None = None  # what to learn (channels.TARGETS); None: ref_diffuse when the dataset holds it, else ref
    init: str | None = None  # start from this checkpoint's weights (its variant and architecture; new inputs at 0)
    device: str = "auto"  # auto (CUDA when present), cpu, cuda; under torchrun each process takes GPU LOCAL_RANK
    amp: str = "auto"  # mixed precision of the training forward pass: auto (bf16 on CUDA, off on CPU), off, bf16
    workers: int = 0  # data-loading worker processes (0: batches are built in the training process)
    cache_mb: float | None = None  # read samples on demand through an LRU of this many MB per process (None: all in memory)
    command: str | None = None

    def check(self) -> None:
        if self.optimizer not in ("adam", "sgd"):
            raise UserError(f"--optimizer must be adam or sgd, not {self.optimizer!r}")
        for name in ("batch", "crop", "epochs", "crops_per_image", "early_stop", "threads"):
            v = getattr(self, name)
            if v is not None and v < 1:
                raise UserError(f"--{name.replace('_', '-')} must be >= 1 (got {v})")
        if self.workers < 0:
            raise UserError(f"--workers must be >= 0 (got {self.workers})")
        if self.cache_mb is not None and not self.cache_mb > 0:
            raise UserError(f"--cache-mb must be > 0 (got {self.cache_mb})")
        if self.device not in ("auto", "cpu", "cuda"):
            raise UserError(f"--device must be auto, cpu or cuda (got {self.device!r})")
        if self.amp not in ("auto", "off", "bf16"):
            raise UserError(f"--amp must be auto, off or bf16 (got {self.amp!r})")
        if self.minutes is not None and not self.minutes > 0:
            raise UserError(f"--minutes must be > 0 (got {self.minutes})")
        if self.lr is not None and not (self.lr > 0 and math.isfinite(self.lr)):
            raise UserError(f"--lr must be a positive number (got {self.lr})")
        if not 0 < self.val_fraction < 1:
            raise UserError(f"validation fraction must be in (0, 1) (got {self.val_fraction})")
        if self.target is not None:
            ch.check_target(self.target)
        if self.variant == "linear":
            raise UserError("the linear variant is fitted in closed form: use `cli.py baseline`")
