"""The learning stages, bpy-free: train, baseline, predict. Each takes a config and returns a summary dict;
torch is imported only when a stage runs (``cli.py --help`` and the configs stay torch-free).

    train(TrainConfig(data="ds/", out="m.pt", minutes=10), progress=..., should_stop=...)   # model/learn/train.py
    baseline(BaselineConfig(data="ds/", out="linear.pt"))                                   # closed form
    predict(PredictConfig(model="m.pt", input="000000.exr", out="pred.exr", png="pred.png"))
    export(ExportConfig(model="m.pt"))                                                      # m.onnx beside it
"""
from __future__ import annotations

from dataclasses import dataclass

from ...model import channels as ch
from ...model.errors import UserError
from ...model.learn.config import TrainConfig


def train(cfg, progress=None, should_stop=None, log=None) -> dict:
    """Train a network (``cfg``: model.learn.config.TrainConfig, which holds the defaults); ``progress(dict)``
    after each logged step (epoch, loss, val_psnr, progress, eta_s); ``should_stop()`` before every batch."""
    from ...model.learn.train import Trainer
    return Trainer(cfg, log=log).run(callback=progress, should_stop=should_stop)


@dataclass
class BaselineConfig:
    """The per-pixel linear-regression baseline, fitted in closed form on the training split."""
    data: str  # dataset folder
    out: str  # checkpoint to write
    inputs: str = ch.format_spec(ch.DEFAULT_INPUTS)  # the seed's inputs
    space: str = "linear"  # regress linear RGB (the seed's) or "log" (log1p RGB)
    seed: int = TrainConfig.seed  # split seed: train's, so that both score the same validation scenes
    val_fraction: float = TrainConfig.val_fraction  # share of scenes for validation (train's)
    command: str | None = None

    def check(self) -> None:
        if self.space not in ("linear", "log"):
            raise UserError(f"--space {self.space!r}: choose linear or log")
        if not 0 < self.val_fraction < 1:
            raise UserError(f"validation fraction must be in (0, 1) (got {self.val_fraction})")
        ch.parse_spec(self.inputs)


def baseline(cfg: BaselineConfig, log=None) -> dict:
    from ...model.learn.baseline import run_baseline
    cfg.check()
    return run_baseline(cfg.data, cfg.out, inputs=cfg.inputs, space=cfg.space, seed=cfg.seed,
                        val_fraction=cfg.val_fraction, command=cfg.command, log=log)


@dataclass
class PredictConfig:
    """One prediction from a sample EXR that holds the model's input groups."""
    model: str  # checkpoint (.pt) from train or baseline
    input: str  # a sample EXR
    out: str  # the prediction as an RGB float EXR (linear HDR)
    png: str | None = None  # also a tonemapped sRGB preview
    threads: int | None = None  # torch / onnxruntime threads
    tile: int | None = None  # tile size for big images (None: the Predictor's)
    runtime: str = "auto"  # model/infer/contract.RUNTIMES: auto (onnxruntime with M.onnx beside M.pt), torch, onnx
    device: str = "auto"  # contract.DEVICES: auto, cpu, cuda, mps (a GPU that is absent: the CPU)
    working_res: str = "auto"  # network resolution (model/infer/workres.py): auto|full|Nx|WxH

    def check(self) -> None:
        for name in ("threads", "tile"):
            v = getattr(self, name)
            if v is not None and v < 0:
                raise UserError(f"--{name} {v}: must be >= 0 (0: the default)")


def predict(cfg: PredictConfig) -> dict:
    from ...model.infer.predict import predict_file
    cfg.check()
    return predict_file(cfg.model, cfg.input, cfg.out, png=cfg.png, threads=cfg.threads, tile=cfg.tile,
                        runtime=cfg.runtime, device=cfg.device,
                        working_res=cfg.working_res)


@dataclass
class ExportConfig:
    """The ONNX export of a checkpoint (model/infer/export.py); needs torch and the onnx package."""
    model: str  # checkpoint (.pt)
    out: str | None = None  # the .onnx to write (None: beside the model, M.onnx)
    command: str | None = None  # recorded in the file's metadata (export_command)


def export(cfg: ExportConfig) -> dict:
    try:
        import onnx  # noqa: F401
        import torch  # noqa: F401
    except ImportError as e:
        raise UserError(f"exporting {cfg.model} to ONNX needs torch and the onnx package ({e}): install them, or "
                        f"export where they are (`pip install onnx`)") from None
    from ...model.infer.export import export as export_
    return export_(cfg.model, cfg.out, command=cfg.command)
