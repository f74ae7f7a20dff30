#!/usr/bin/env python3
"""Prediction time of the two runtimes on the same model, inputs and threads, in one run (docs/onnx.md).

    .venv/bin/python benchmarks/onnx_speed.py [--model models/ssgi_default.pt] [--sizes 240x135 960x540 1920x1080] \
        [--threads 2] [--repeats 7] [--out speed.json]

For each size: the whole ``predict()`` (the contract around the network included: what the node pays) of the
torch runtime (fp32 channels_last, the CPU default) and of onnxruntime (the .onnx export beside the model),
alternating torch / onnxruntime call by call so that a change of machine load hits both alike; the median and
the minimum of the repeats, after one warm-up call each; the process CPU time of each call (all threads: less
sensitive than wall time to other processes on a loaded machine); and the contract's own share (normalisation, scene
statistics, bound and masks: ``normalize.to_inputs`` + ``contract.finish``), which both runtimes pay alike.
Prints one line per size and a JSON summary on stdout.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

import _bootstrap  # noqa: F401  (the checkout as package ssgi)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default=str(_bootstrap.ROOT / "models" / "ssgi_default.pt"))
    ap.add_argument("--sizes", nargs="+", default=["240x135", "960x540", "1920x1080"])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default=None, metavar="JSON")
    a = ap.parse_args(argv)

    from ssgi.model import cliargs, normalize
    from ssgi.model.infer import contract, export, predictor
    torch_p = predictor.load_predictor(a.model, num_threads=a.threads, runtime="torch", device="cpu")
    ort_p = predictor.load_predictor(a.model, num_threads=a.threads, runtime="onnx", device="cpu")
    rows = []
    for s in a.sizes:
        w, h = cliargs.parse_size(s)
        g = export.hdr_groups(w, h)
        n = a.repeats if w * h < 1e6 else max(3, a.repeats // 2)
        times = {"torch": [], "onnx": []}
        cpu = {"torch": [], "onnx": []}
        outs = {k: p.predict(g) for k, p in (("torch", torch_p), ("onnx", ort_p))}  # warm-up
        for _ in range(n):
            for k, p in (("torch", torch_p), ("onnx", ort_p)):
                t, c = time.perf_counter(), time.process_time()
                p.predict(g)
                times[k].append(1000 * (time.perf_counter() - t))
                cpu[k].append(1000 * (time.process_time() - c))
        t = time.perf_counter()
        for _ in range(n):
            x, _ = normalize.to_inputs(g, torch_p.spec)
            contract.finish(outs["onnx"].copy(), g, torch_p.spec, torch_p.required)
        own = 1000 * (time.perf_counter() - t) / n
        row = dict(size=f"{w}x{h}", repeats=n, contract_ms=round(own, 1),
                   **{f"{k}_ms": round(statistics.median(v), 1) for k, v in times.items()},
                   **{f"{k}_min_ms": round(min(v), 1) for k, v in times.items()},
                   **{f"{k}_cpu_ms": round(statistics.median(v), 1) for k, v in cpu.items()},
                   max_rel_diff=export.rel_diff(outs["onnx"], outs["torch"]))
        row["torch_over_onnx"] = round(row["torch_ms"] / row["onnx_ms"], 2)
        rows.append(row)
        print(f"{row['size']:>10}: torch {row['torch_ms']:8.1f} ms (min {row['torch_min_ms']:.1f})  onnxruntime "
              f"{row['onnx_ms']:8.1f} ms (min {row['onnx_min_ms']:.1f})  torch/ort {row['torch_over_onnx']:.2f}x  "
              f"contract {row['contract_ms']:.1f} ms  CPU time torch {row['torch_cpu_ms']:.0f} / ort {row['onnx_cpu_ms']:.0f} ms  "
              f"max rel diff {row['max_rel_diff']:.1e}", file=sys.stderr, flush=True)
    import onnxruntime
    import torch
    res = dict(model=a.model, threads=a.threads, torch=torch.__version__, onnxruntime=onnxruntime.__version__,
               cpus=os.cpu_count(), load_average=os.getloadavg(), rows=rows)
    if a.out:
        from ssgi.model import files
        files.write_json(a.out, res)
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
