"""Benchmark: training throughput (samples/s = training crops per second) and minutes to a validation PSNR, for
one process and for N processes under torchrun, on CUDA or CPU, with and without bf16 mixed precision.

    .venv/bin/python benchmarks/gpu_train.py --device cuda --nproc 1 8 --amp off bf16 --data DIR --target-psnr 26.82
    .venv/bin/python benchmarks/gpu_train.py --device cpu --nproc 1 2 --threads 2      # 2 CPU cores: 1 vs 2 processes

Each configuration is one ``cli.py train`` run (``torchrun --standalone --nproc_per_node N`` for N > 1) with the
same global batch; the numbers come from its checkpoint history (``minutes`` counts training batches, not
validation): samples/s over epochs 2.. (epoch 1 holds start-up, CUDA init and kernel autotuning), and samples
per CPU second (rank 0's process CPU time, validation included, loader workers not, times the process count:
the fairer number on a loaded machine); minutes to ``--target-psnr``: the first epoch whose validation PSNR reaches it (default
26.82 dB, the shipped model's on its artist bake (the artist folder of its training data): meaningful only on that dataset with its
inputs). Without ``--data`` a synthetic
set (model/dataset/synthetic.py) of ``--samples`` at ``--size`` is made in a temporary folder. With several
processes on CPU each gets ``--threads`` / N threads, so the cores are the same. Prints one JSON line per run
and, with ``--out``, writes them all.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package "ssgi")

ROOT = Path(__file__).resolve().parent.parent
SHIPPED_PSNR = 26.82  # models/ssgi_default.pt best val_psnr (epoch 7 of its run, on its artist folder)


def one_run(data, out, nproc, device, amp, a) -> dict:
    from ssgi.model.learn import checkpoint
    args = ["train", "--data", str(data), "--out", str(out), "--variant", a.variant, "--crop", str(a.crop),
            "--batch", str(a.batch), "--device", device, "--amp", amp, "--workers", str(a.workers), "--quiet",
            "--seed", "0"] + (["--inputs", a.inputs] if a.inputs else [])
    args += ["--epochs", str(a.epochs)] if a.epochs else ["--minutes", str(a.minutes)]
    if a.cache_mb:
        args += ["--cache-mb", str(a.cache_mb)]
    if a.crops_per_image:
        args += ["--crops-per-image", str(a.crops_per_image)]
    env = dict(os.environ)
    threads = max(1, a.threads // nproc) if device == "cpu" and a.threads else None
    if threads:
        env["OMP_NUM_THREADS"] = str(threads)
        args += ["--threads", str(threads)]
    if nproc > 1:
        cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", str(nproc),
               str(ROOT / "cli.py")] + args
    else:
        cmd = [sys.executable, str(ROOT / "cli.py")] + args
    p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"gpu_train.py: {' '.join(cmd)} failed:\n{p.stderr[-3000:]}")
    h = checkpoint.load(checkpoint.last_path(out))["history"]
    first = h[0] if len(h) > 1 else dict(step=0, minutes=0.0)
    rate = (h[-1]["step"] - first["step"]) * a.batch / max(1e-9, 60 * (h[-1]["minutes"] - first["minutes"]))
    cpu = (h[-1].get("cpu_minutes", 0) - first.get("cpu_minutes", 0)) * 60 * nproc  # rank 0's, x processes
    hit = next((e for e in h if e["val_psnr"] >= a.target_psnr), None)
    return dict(nproc=nproc, device=device, amp=amp, threads_per_process=threads, workers=a.workers, cache_mb=a.cache_mb,
                batch=a.batch, crop=a.crop,
                epochs=len(h), steps=h[-1]["step"], samples_per_s=round(rate, 2),
                samples_per_cpu_s=round((h[-1]["step"] - first["step"]) * a.batch / cpu, 2) if cpu > 0 else None,
                best_val_psnr=round(max(e["val_psnr"] for e in h), 4), last_val_psnr=round(h[-1]["val_psnr"], 4),
                val_psnr=[round(e["val_psnr"], 4) for e in h], target_psnr=a.target_psnr,
                minutes_to_target=round(hit["minutes"], 3) if hit else None, train_minutes=round(h[-1]["minutes"], 3))


def step_bench(device: str, a) -> dict:
    """The network's training step alone (forward, loss, backward, Adam) on random crops, float32 against bf16
    autocast, interleaved repetitions in one process: the mixed-precision ratio without data loading."""
    import statistics
    import time

    import torch

    from ssgi.model import channels as ch
    from ssgi.model.learn import network
    if a.threads:
        torch.set_num_threads(a.threads)
    spec = ch.parse_spec(a.inputs) if a.inputs else ch.DEFAULT_INPUTS
    dev = torch.device(device)
    net = network.build(network.arch_for(a.variant, spec, target=ch.DIFFUSE_TARGET)).to(dev, memory_format=torch.channels_last)
    x = torch.randn(a.batch, ch.input_channels(spec), a.crop, a.crop, device=dev).contiguous(memory_format=torch.channels_last)
    opt = torch.optim.Adam(net.parameters())

    def step(bf16: bool) -> float:
        if dev.type == "cuda":
            torch.cuda.synchronize()
        t = time.perf_counter()
        with torch.autocast(dev.type, dtype=torch.bfloat16, enabled=bf16):
            out = net(x)
        loss = (out.float() ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        if dev.type == "cuda":
            torch.cuda.synchronize()
        return time.perf_counter() - t

    for bf16 in (False, True, False, True):
        step(bf16)
    times = {False: [], True: []}
    for _ in range(a.step_repeats):
        for bf16 in (False, True):
            times[bf16].append(step(bf16))
    fp, bf = statistics.median(times[False]), statistics.median(times[True])
    return dict(step_bench=True, device=device, variant=a.variant, batch=a.batch, crop=a.crop, threads=a.threads,
                fp32_ms=round(fp * 1000, 2), bf16_ms=round(bf * 1000, 2), bf16_over_fp32=round(bf / fp, 3),
                fp32_samples_per_s=round(a.batch / fp, 1), bf16_samples_per_s=round(a.batch / bf, 1))


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", help="dataset folder (default: a synthetic one)")
    ap.add_argument("--samples", type=int, default=40, help="synthetic samples (default %(default)s)")
    ap.add_argument("--size", default="160x90", help="synthetic WxH (default %(default)s)")
    ap.add_argument("--device", default="cuda", choices=("cuda", "cpu"))
    ap.add_argument("--nproc", type=int, nargs="+", default=[1], help="process counts to run (default 1)")
    ap.add_argument("--amp", nargs="+", default=["off", "bf16"], choices=("off", "bf16"))
    ap.add_argument("--threads", type=int, default=None, help="CPU: threads shared by the processes of a run")
    ap.add_argument("--workers", type=int, default=0, help="data-loading workers per process")
    ap.add_argument("--cache-mb", type=float, default=None, help="read samples on demand through this cache")
    ap.add_argument("--variant", default="unet_s")
    ap.add_argument("--inputs", default=None, help="input spec (default: train's)")
    ap.add_argument("--crop", type=int, default=128)
    ap.add_argument("--batch", type=int, default=32, help="global batch (default %(default)s)")
    ap.add_argument("--crops-per-image", type=int, default=None)
    ap.add_argument("--epochs", type=int, default=None)
    ap.add_argument("--minutes", type=float, default=2.0, help="budget per run when --epochs is not given")
    ap.add_argument("--target-psnr", type=float, default=SHIPPED_PSNR)
    ap.add_argument("--step-bench", action="store_true",
                    help="first time the network's step alone, float32 against bf16 autocast (medians)")
    ap.add_argument("--step-repeats", type=int, default=12)
    ap.add_argument("--out", help="also write the rows as JSON here")
    a = ap.parse_args(argv)
    rows = []
    if a.step_bench:
        rows.append(step_bench(a.device, a))
        print(json.dumps(rows[-1]), flush=True)
    with tempfile.TemporaryDirectory(prefix="ssgi-gpu-train-") as tmp:
        data = a.data
        if not data:
            from ssgi.model.dataset import synthetic
            w, h = (int(v) for v in a.size.lower().split("x"))
            data = synthetic.make_dataset(Path(tmp) / "syn", scenes=max(2, a.samples // 2), per_scene=2, w=w, h=h,
                                          seed=3, shipped=True)  # every group train's default inputs read
        for amp in a.amp:
            for n in a.nproc:
                row = one_run(data, Path(tmp) / f"m{n}{amp}.pt", n, a.device, amp, a)
                print(json.dumps(row), flush=True)
                rows.append(row)
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    main()
