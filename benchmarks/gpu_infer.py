#!/usr/bin/env python3
"""Prediction speed and parity on a GPU, prepared for a machine with one; on one without, it runs on the CPU and says so.

    .venv/bin/python benchmarks/gpu_infer.py [--model models/ssgi_default.pt] [--size 1920x1080] [--repeats 5]

Predicts the same synthetic HDR frame (export.hdr_groups) with: torch on the CPU (fp32, the reference), torch
on CUDA in fp32 and fp16, onnxruntime on the CPU and onnxruntime with the CUDA execution provider (needs the
``onnxruntime-gpu`` build; the CPU build falls back to the CPU, which the output names). For each: the device it
really ran on, the first call (warm-up: cuDNN autotuning, the runtime's start), the median of the repeats, and the
largest relative difference from the CPU reference (export.rel_diff) and the largest difference over float32's
rounding bound (export.bound_ratio, <= 1: rounding alone; fp16 and TF32 runs exceed it by design). One JSON object on stdout; never fails for
want of a GPU (``cuda_available`` false, every device "cpu").
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import _bootstrap  # noqa: F401  (the checkout as package ssgi)


def timed(pred, g, repeats: int) -> tuple[dict, object]:
    t = time.perf_counter()
    out = pred.predict(g)
    first = time.perf_counter() - t
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        pred.predict(g)
        ts.append(time.perf_counter() - t)
    return dict(first_ms=round(1000 * first, 1), median_ms=round(1000 * statistics.median(ts), 1)), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default=str(_bootstrap.ROOT / "models" / "ssgi_default.pt"))
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=None, help="CPU threads (default: all)")
    a = ap.parse_args(argv)

    import torch

    from ssgi.model import cliargs
    from ssgi.model.infer import export, onnx as ort_backend, predictor
    w, h = cliargs.parse_size(a.size)
    g = export.hdr_groups(w, h)
    res = dict(model=a.model, size=f"{w}x{h}", torch=torch.__version__, cuda_available=torch.cuda.is_available(),
               gpu=torch.cuda.get_device_name(0) if torch.cuda.is_available() else None, runs={})
    try:
        import onnxruntime
        res.update(onnxruntime=onnxruntime.__version__, ort_providers=onnxruntime.get_available_providers())
    except ImportError as e:
        res["onnxruntime"] = f"not importable: {e}"
    ref_pred = predictor.load_predictor(a.model, num_threads=a.threads, runtime="torch", precision="fp32", device="cpu")
    res["runs"]["torch cpu fp32"], ref = timed(ref_pred, g, max(1, a.repeats // 2))
    res["runs"]["torch cpu fp32"].update(device="cpu", max_rel_vs_cpu=0.0, max_ratio_vs_cpu=0.0)
    todo = [("torch cuda fp32", dict(runtime="torch", device="cuda", precision="fp32")),
            ("torch cuda fp16", dict(runtime="torch", device="cuda", precision="fp16")),
            ("onnxruntime cpu", dict(runtime="onnx", device="cpu")),
            ("onnxruntime cuda", dict(runtime="onnx", device="cuda"))]
    for name, kw in todo:
        try:
            pred = predictor.load_predictor(a.model, num_threads=a.threads, **kw)
            r, out = timed(pred, g, a.repeats)
            r.update(device=pred.device, precision=getattr(pred, "precision", None), max_rel_vs_cpu=export.rel_diff(out, ref),
                     max_ratio_vs_cpu=export.bound_ratio(ref_pred, g, ref, out),
                     note=getattr(pred, "device_note", "") or None)
            if kw["runtime"] == "onnx":
                r["providers"] = pred.sess.get_providers()
            res["runs"][name] = r
        except Exception as e:  # a broken GPU stack is a result to report, not a crash
            res["runs"][name] = dict(error=f"{type(e).__name__}: {e}"[:300])
        print(f"{name:>18}: {res['runs'][name]}", file=sys.stderr, flush=True)
    res["has_gpu_provider"] = ort_backend.has_gpu_provider("cuda")
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
