"""Prediction benchmark (``cli.py bench``): time and peak memory of each variant at several sizes.

Times the whole ``Predictor.predict`` (normalisation + network + output transform, tiled as shipped) on
synthetic inputs, the median of ``repeats`` runs after one warm-up, with ``torch.set_num_threads(threads)``.
Untrained variants time the same as trained ones (the weights do not change the work). Peak memory is the
growth of the process's peak resident set (VmHWM, reset through /proc/self/clear_refs) during the runs.

``peak_memory`` measures one cold prediction in a fresh Python process instead (the report's scaling table):
the child runs ``cold_prediction`` of this module.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .. import channels as ch, cliargs, files
from ..errors import UserError


def _vm(key: str) -> int:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _reset_peak() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def synthetic_groups(w: int, h: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Random inputs for every stored input group of the channel spec (by its kind when not listed here)."""
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(h, w, 3)).astype(np.float32)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    g = dict(albedo=rng.uniform(0, 1, (h, w, 3)).astype(np.float32), normal=n,
             depth=rng.uniform(1, 10, (h, w, 1)).astype(np.float32),
             direct=rng.exponential(1.0, (h, w, 3)).astype(np.float32),
             ao=rng.uniform(0, 1, (h, w, 1)).astype(np.float32),
             world=np.broadcast_to(rng.uniform(0, 1, 3).astype(np.float32), (h, w, 3)).copy())
    for name in ch.required_groups(ch.INPUT_GROUPS):
        if name not in g:
            grp = ch.GROUPS[name]
            draw = rng.exponential(1.0, (h, w, grp.size)) if grp.kind == "light" else rng.uniform(0, 1, (h, w, grp.size))
            g[name] = draw.astype(np.float32)
    return {k: v for k, v in g.items() if k in ch.GROUPS}


def time_predictor(pred, w: int, h: int, repeats: int = 5) -> dict:
    groups = synthetic_groups(w, h)
    pred.predict(groups)  # warm-up
    base = _vm("VmRSS")
    ok = _reset_peak()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        pred.predict(groups)
        ts.append(time.perf_counter() - t)
    peak = (_vm("VmHWM") - base) if ok else None
    return dict(ms=1000 * float(np.median(ts)), ms_min=1000 * float(np.min(ts)),
                peak_mb=None if peak is None else max(0, peak) / 2 ** 20)


_PEAK_CHILD = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import cli
cli.load_package()
from ssgi.model.infer import bench
print("PEAK" + json.dumps(bench.cold_prediction(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]),
                                                sys.argv[6])))
"""


def cold_prediction(model, w: int, h: int, threads: int = 1, working_res: str = "full") -> dict:
    """Load ``model`` and predict once at ``w`` x ``h``: the growth of the process's peak resident set over
    its resident set just before ``predict`` (model and inputs loaded), and the time of that first prediction.
    Meaningful in a fresh process only (``peak_memory`` runs it in one)."""
    from . import predictor
    from .workres import WorkingResolution

    pred = WorkingResolution(predictor.load_predictor(model, num_threads=threads, runtime="torch"), working_res)
    g = synthetic_groups(w, h)
    before = _vm("VmRSS")
    t = time.perf_counter()
    pred.predict(g)
    dt = time.perf_counter() - t
    return dict(peak_mb=(_vm("VmHWM") - before) / 2 ** 20, first_ms=1000 * dt)


def peak_memory(model, w: int, h: int, threads: int = 1, timeout: float = 600, working_res: str = "full") -> dict:
    """Peak memory of one prediction at ``w`` x ``h`` in a fresh Python process (nothing to reuse): the
    process's peak resident set during ``predict`` minus its resident set just before (model and inputs
    loaded). Also the time of that first, cold prediction, at ``working_res`` (model/infer/workres.py). On a
    failure: ``peak_mb`` None and ``error``."""
    root = Path(__file__).resolve().parents[2]
    p = subprocess.run([sys.executable, "-c", _PEAK_CHILD, str(root), str(model), str(w), str(h), str(threads),
                        str(working_res)],
                       capture_output=True, text=True, timeout=timeout)
    line = next((l for l in p.stdout.splitlines() if l.startswith("PEAK")), None)
    if p.returncode != 0 or line is None:
        return dict(peak_mb=None, error=(p.stderr.strip().splitlines() or ["?"])[-1][:200])
    return json.loads(line[4:])


def bench(variants=None, models=(), sizes=("240x135",), threads=2, repeats=5, precisions=("fp32",), out=None) -> dict:
    import torch

    from ..learn import checkpoint, network, variants as V
    from . import predictor

    torch.set_num_threads(threads)
    sizes = [tuple(cliargs.parse_size(s)) for s in sizes]
    names = list(variants) if variants is not None else list(V.TRAINABLE) + ["linear"]
    for name in names:  # every argument is checked before any timing
        if name not in V.VARIANTS:
            raise UserError(f"unknown variant {name!r}; known: {', '.join(V.VARIANTS)}")
    if out and not Path(out).expanduser().resolve().parent.is_dir():
        raise UserError(f"--out {out}: folder {Path(out).expanduser().resolve().parent} does not exist")
    given = {}
    for m in models:
        ck = checkpoint.load(m)
        given[m] = (ck, checkpoint.build_net(ck, m))
    rows = []
    todo = [(n, None) for n in names] + [(None, m) for m in models]
    for name, model in todo:
        if model is None:
            torch.manual_seed(0)
            net = network.build(network.arch_for(name))
            ckpt = checkpoint.make(net.eval(), "network", command="bench")
        else:
            ckpt, net = given[model]
        label = name or str(model)
        macs = network.macs_per_pixel(net)
        for prec in precisions:
            pred = predictor.Predictor(net, ckpt, path=label, precision=prec)
            for w, h in sizes:
                r = time_predictor(pred, w, h, repeats if w * h < 1e6 else max(1, repeats // 2))
                row = dict(model=label, precision=prec, size=f"{w}x{h}", params=network.count_params(net),
                           macs_per_px=macs, **r)
                rows.append(row)
                print(f"{label:>10} {prec:>8} {w:>5}x{h:<5} {r['ms']:9.1f} ms (min {r['ms_min']:.1f})"
                      + (f"  peak +{r['peak_mb']:.0f} MB" if r["peak_mb"] is not None else ""), file=sys.stderr, flush=True)
    res = dict(threads=threads, torch=torch.__version__, rows=rows)
    if out:
        files.write_json(out, res)
    return res
