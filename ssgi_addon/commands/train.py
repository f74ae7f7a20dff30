"""Subcommands ``train``, ``baseline``, ``predict``, ``export`` (the learning stages, ssgi_addon/pipeline/learn.py),
``curves`` and ``bench`` behind argparse (torch is imported inside ``run``)."""
from __future__ import annotations

import json
import os
import sys

from ...model import channels as ch
from ...model.cliargs import existing_file, existing_model, model_arg, working_res
from ..pipeline.learn import BaselineConfig, ExportConfig, PredictConfig
from . import command_line


def _arch_overrides(text: str | None) -> dict:
    from ...model.errors import UserError
    if not text:
        return {}
    try:
        d = json.loads(text)
    except ValueError as e:
        raise UserError(f"--arch must be a JSON object such as '{{\"width\": 32}}' ({e})") from None
    if not isinstance(d, dict):
        raise UserError("--arch must be a JSON object such as '{\"width\": 32}'")
    return d


def run_train(args) -> dict:
    from ...model.learn.config import TrainConfig
    from tqdm import tqdm

    from ..pipeline import learn

    cfg = TrainConfig(data=str(args.data[0]) if len(args.data) == 1 else [str(d) for d in args.data], out=args.out, variant=args.variant, inputs=args.inputs,
                      arch=_arch_overrides(args.arch), minutes=args.minutes, epochs=args.epochs, resume=args.resume,
                      optimizer=args.optimizer, lr=args.lr, clip=args.clip, batch=args.batch, crop=args.crop,
                      crops_per_image=args.crops_per_image, early_stop=args.early_stop, threads=args.threads,
                      seed=args.seed, val_fraction=args.val_fraction, target=args.target, init=args.init,
                      device=args.device, amp=args.amp, workers=args.workers, cache_mb=args.cache_mb,
                      command=command_line())
    rank0 = os.environ.get("RANK", "0") == "0"  # under torchrun rank 0 reports (progress, --json)
    if not rank0:
        args.json = False
    bar = tqdm(total=1000, file=sys.stderr, unit="‰", disable=args.quiet or not rank0, bar_format="{l_bar}{bar}| {postfix}")

    def cb(d):
        bar.n = int(1000 * d["progress"])
        bar.set_postfix_str(f"ep {d['epoch']} loss {d['loss']:.4f} val {d['val_psnr'] or float('nan'):.2f} dB"
                            + (f" eta {d['eta_s'] / 60:.1f} min" if d.get("eta_s") is not None else ""))

    try:
        res = learn.train(cfg, progress=cb, log=(lambda m: bar.write(m, file=sys.stderr)))
    finally:
        bar.close()
    return res


def run_baseline(args) -> dict:
    from ..pipeline import learn
    return learn.baseline(BaselineConfig(data=args.data, out=args.out, inputs=args.inputs, space=args.space,
                                         seed=args.seed, val_fraction=args.val_fraction, command=command_line()))


def run_predict(args) -> dict:
    from ..pipeline import learn
    res = learn.predict(PredictConfig(model=args.model, input=args.input, out=args.out, png=args.png,
                                      threads=args.threads, tile=args.tile, runtime=args.runtime,
                                      device=args.device, working_res=args.working_res))
    msg = (f"wrote {res['out']} ({res['size'][1]}x{res['size'][0]}) in {res['seconds'] * 1000:.0f} ms "
           f"({res['runtime']} on {res['device']})")
    if "psnr" in res:
        msg += f"; PSNR vs ref {res['psnr']:.2f} dB (tm {res['tm_psnr']:.2f}, SSIM {res['ssim']:.3f})"
    if res["repaired_pixels"]:
        msg += f"; repaired {res['repaired_pixels']} non-finite input pixel(s)"
    print(msg, file=sys.stderr)
    return res


def run_export(args) -> dict:
    from ..pipeline import learn
    res = learn.export(ExportConfig(model=args.model, out=args.out, command=command_line()))
    print(f"wrote {res['out']} ({res['bytes'] / 1024:.0f} KB, opset {res['opset']}); onnxruntime vs torch on HDR "
          f"inputs: max relative difference {res['parity']['max_rel']:.1e}", file=sys.stderr)
    return res


def add_runtime_args(p) -> None:
    """``--runtime`` and ``--device`` (model/infer/predictor.load_predictor), for predict and render."""
    from ...model.infer.contract import DEVICES, RUNTIMES
    p.add_argument("--runtime", default="auto", choices=RUNTIMES,
                   help="what runs the network: auto (onnxruntime when M.onnx, exported from M.pt, lies beside it; "
                        "else torch), torch or onnx (default %(default)s)")
    p.add_argument("--device", default="auto", choices=DEVICES,
                   help="where: auto (a GPU the runtime can use, else the CPU), cpu, cuda, mps; a GPU that is "
                        "absent falls back to the CPU (default %(default)s)")


def run_bench(args) -> dict:
    from ...model.infer.bench import bench
    return bench(variants=args.variants, models=args.models, sizes=args.sizes, threads=args.threads,
                 repeats=args.repeats, precisions=args.precision, out=args.out)


def run_curves(args) -> dict:
    from ...model.learn.curves import compare_png
    rows = compare_png(args.models, args.out, cpu=args.cpu)
    for r in rows:
        print(f"{r['variant']:>10} {r['params'] or 0:>8} params  best val PSNR {r['best_val_psnr']:.2f} dB  "
              f"after {r['minutes']:.1f} min ({r['epochs']} epochs)  {r['model']}", file=sys.stderr)
    return dict(out=args.out, rows=rows)


def register_cli(sub) -> None:
    from ...model.learn import variants
    from ...model.learn.config import ADAM_LR, DEFAULT_MINUTES, SGD_LR, TrainConfig as T

    p = sub.add_parser("train", help="train a network on a baked dataset",
                       description="Train a network on a dataset folder; without options, the shipped default "
                                   "model's network and recipe. MODEL is the best checkpoint so far "
                                   "(by validation PSNR); MODEL.last.pt beside it is the resume point; "
                                   "MODEL.curve.png the learning curve. Several processes or machines: "
                                   "torchrun --nproc_per_node N cli.py train ... (--batch is the global batch).")
    p.add_argument("--data", required=True, nargs="+", metavar="DIR",
                   help="dataset folder (manifest.json + EXR samples); several train together, each split "
                        "into train/validation by its own scenes")
    p.add_argument("--out", required=True, metavar="MODEL", help="checkpoint to write (e.g. models/ssgi.pt)")
    p.add_argument("--variant", default=T.variant, choices=variants.TRAINABLE,
                   help=f"network variant (default {T.variant})")
    p.add_argument("--arch", metavar="JSON", help='override variant settings, e.g. \'{"widths": [16, 32, 48]}\'')
    p.add_argument("--inputs", default=T.inputs, metavar="SPEC",
                   help="input groups, comma-separated (default: %(default)s)")
    p.add_argument("--init", metavar="M.pt", default=None, type=existing_file,
                   help="start from this checkpoint's weights, variant and architecture; inputs it lacks start at 0, "
                        "so training begins from exactly its predictions (e.g. the shipped model)")
    p.add_argument("--target", choices=ch.TARGETS, default=T.target,
                   help="what the network learns: ref_diffuse, the diffuse part of the Cycles image, which the render "
                        "path adds to EEVEE's own emission, reflections and glass (default when the dataset holds it), "
                        "ref, the whole image (datasets baked without ref_diffuse), or ref_combined, the Cycles image "
                        "from EEVEE's GI-off Combined image (one-render models)")
    p.add_argument("--minutes", type=float,
                   help=f"time budget in minutes (default {DEFAULT_MINUTES:g} when --epochs is not given)")
    p.add_argument("--epochs", type=int, help="number of epochs")
    p.add_argument("--resume", action="store_true", help="continue from MODEL.last.pt (same steps, optimizer, RNG)")
    p.add_argument("--optimizer", default=T.optimizer, choices=("adam", "sgd"))
    p.add_argument("--lr", type=float, default=T.lr,
                   help=f"learning rate (default {ADAM_LR:g} with adam, {SGD_LR:g} with sgd)")
    p.add_argument("--clip", type=float, help="gradient-norm clipping (default 1.0 for sgd, off for adam)")
    p.add_argument("--batch", type=int, default=T.batch, help="crops per batch (default %(default)s)")
    p.add_argument("--crop", type=int, default=T.crop, help="crop size in pixels (default %(default)s)")
    p.add_argument("--crops-per-image", type=int, help="crops of each image per epoch (default: image area / crop area)")
    p.add_argument("--early-stop", type=int, metavar="N", help="stop after N epochs without validation improvement")
    p.add_argument("--threads", type=int, help="torch threads (default: torch's own, all cores)")
    p.add_argument("--seed", type=int, default=T.seed)
    p.add_argument("--val-fraction", type=float, default=T.val_fraction,
                   help="share of scenes for validation (default %(default)s)")
    p.add_argument("--device", default=T.device, choices=("auto", "cpu", "cuda"),
                   help="auto: CUDA when torch sees a GPU (under torchrun, GPU LOCAL_RANK), else CPU")
    p.add_argument("--amp", default=T.amp, choices=("auto", "off", "bf16"),
                   help="mixed precision of the forward pass: auto = bf16 on CUDA, off on CPU (default %(default)s)")
    p.add_argument("--workers", type=int, default=T.workers,
                   help="data-loading worker processes per training process (default %(default)s)")
    p.add_argument("--cache-mb", type=float, default=T.cache_mb, metavar="MB",
                   help="read samples on demand through an LRU cache of MB per process (training process and each "
                        "worker) instead of loading the whole dataset into memory")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run_train)

    B = BaselineConfig
    p = sub.add_parser("baseline", help="fit the per-pixel linear-regression baseline in closed form")
    p.add_argument("--data", required=True, metavar="DIR")
    p.add_argument("--out", required=True, metavar="MODEL")
    p.add_argument("--inputs", default=B.inputs, metavar="SPEC")
    p.add_argument("--space", default=B.space, choices=("linear", "log"),
                   help="regress linear RGB (the seed's) or log1p RGB (default %(default)s)")
    p.add_argument("--seed", type=int, default=B.seed, help="split seed (same as train's)")
    p.add_argument("--val-fraction", type=float, default=B.val_fraction)
    p.set_defaults(func=run_baseline)

    p = sub.add_parser("predict", help="run a model on one sample EXR")
    p.add_argument("--model", required=True, metavar="M", type=model_arg,
                   help="a shipped model's name (default, one_render), a checkpoint (.pt) from train or baseline, or "
                        "its .onnx export")
    p.add_argument("--input", required=True, metavar="SAMPLE.exr", help="a sample EXR holding the model's input groups")
    p.add_argument("--out", required=True, metavar="OUT.exr", help="prediction as an RGB float EXR (linear HDR)")
    p.add_argument("--png", metavar="OUT.png", help="also write a tonemapped sRGB preview")
    p.add_argument("--threads", type=int, help="torch / onnxruntime threads")
    p.add_argument("--tile", type=int, help="tile size for big images (default 1024)")
    add_runtime_args(p)
    p.add_argument("--working-res", type=working_res, default="auto", metavar="auto|full|Nx|WxH",
                   help="resolution the network predicts at, upsampled with the sample's full-resolution G-buffer "
                        "(default auto: from 960 px wide 1/4 per axis for a one-render model, else a working image 480 "
                        "px wide; below, full)")
    p.set_defaults(func=run_predict)

    p = sub.add_parser("export", help="export a checkpoint as ONNX (runs without torch, in the bundled onnxruntime)",
                       description="Write the network of a checkpoint as an ONNX graph (dynamic H, W) with the "
                                   "checkpoint's metadata, and check it against torch on HDR inputs. The SSGI node, "
                                   "render and predict use M.onnx beside M.pt when torch is absent (or faster). "
                                   "Needs torch and the onnx package.")
    p.add_argument("--model", required=True, metavar="M.pt", type=existing_model,
                   help="a shipped model's name (default, one_render) or a checkpoint from train or baseline")
    p.add_argument("--out", default=None, metavar="M.onnx", help="the ONNX file (default: beside the model, M.onnx)")
    p.set_defaults(func=run_export)

    p = sub.add_parser("curves", help="plot the learning curves of several models in one PNG")
    p.add_argument("--models", nargs="+", required=True, metavar="M", help="checkpoints (train or baseline)")
    p.add_argument("--out", required=True, metavar="PNG")
    p.add_argument("--cpu", action="store_true", help="x axis: CPU minutes instead of wall minutes (needs cpu_minutes in the history)")
    p.set_defaults(func=run_curves)

    p = sub.add_parser("bench", help="time prediction of each variant at several sizes",
                       description="Prints prediction time (median of --repeats) and peak memory per variant and size.")
    p.add_argument("--variants", nargs="*", default=None, help="variants (default: all trainable)")
    p.add_argument("--models", nargs="*", default=[], help="checkpoints to time as well")
    p.add_argument("--sizes", nargs="*", default=["240x135", "960x540", "1920x1080"], help="WxH sizes")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--precision", nargs="*", default=["fp32"], choices=("fp32", "fp32-cl", "bf16-cl"),
                   help="fp32 (NCHW), fp32-cl (channels_last), bf16-cl (bfloat16 channels_last)")
    p.add_argument("--out", metavar="JSON", help="also write the numbers to this file")
    p.set_defaults(func=run_bench)
