"""What a shot's lightmap (model/infer/lightmap.py) costs the node a frame: ``Lightmap.apply`` at artist sizes.

    .venv/bin/python benchmarks/lightmap_cost.py [--model shot.pt] [--sizes 240x135,960x540,1920x1080] [--repeats 3]

The field is the model's lightmap (``--model``: its ``.lightmap.npz``), or one of the fit's shape (model/learn/
lightmap.py: HIDDEN wide, LAYERS layers) with random weights: the cost does not depend on the weights. The frame is a
room-like G-buffer (a floor, walls, a box) at each size; the working-resolution factor is the node's "auto" one
(model/infer/workres.py: 4 from 960 wide). Prints seconds (best of the repeats) and the peak memory the apply adds
(tracemalloc: numpy's allocations) per size, as JSON lines.
"""
from __future__ import annotations

import argparse
import json
import time
import tracemalloc

import _bootstrap  # noqa: F401  (the checkout as package "ssgi")
import numpy as np

from ssgi.model.infer import lightmap as lm, workres
from ssgi.model.learn import lightmap as llm


def frame(w: int, h: int, seed: int = 0) -> dict:
    """A G-buffer of a box in a room seen from the origin, looking down -Z (camera space normals)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w]
    depth = np.where(y > 0.6 * h, 3.0 + 4.0 * (h - y) / h, 7.0).astype(np.float32)
    box = (abs(x - w / 2) < w / 8) & (abs(y - 0.6 * h) < h / 8)
    depth[box] = 4.0
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = 1.0
    normal[y > 0.6 * h] = (0.0, 0.8, 0.6)
    normal[box] = (0.0, 0.0, 1.0)
    albedo = np.full((h, w, 3), 0.6, np.float32)  # flat colours: the blend covers the faces, not only the edges
    albedo[box] = (0.3, 0.5, 0.2)
    albedo[y > 0.6 * h] *= np.float32(0.8) + np.float32(0.05) * (rng.random() > 2)
    return {"depth": depth[..., None], "normal": normal, "albedo": albedo}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=None, help="a fitted model whose lightmap to time (default: random weights)")
    ap.add_argument("--sizes", default="240x135,960x540,1920x1080")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args(argv)
    if a.model:
        field = lm.Lightmap.load(lm.path_for(a.model))
        field.lam = field.lam or 0.5
    else:
        rng = np.random.default_rng(0)
        dims = [6 + 6 * lm.NFREQ] + [llm.HIDDEN] * llm.LAYERS + [3]
        field = lm.Lightmap([(rng.normal(0, 0.1, (o, i)), np.zeros(o)) for i, o in zip(dims[:-1], dims[1:])],
                            [-5, -5, -8], [5, 5, 0], lm.NFREQ, 0.75)
    P = np.array([[2.78, 0, 0, 0], [0, 4.94, 0, 0], [0, 0, -1.002, -0.2], [0, 0, -1, 0]])
    for size in a.sizes.split(","):
        w, h = map(int, size.split("x"))
        g = frame(w, h)
        part = np.full((h, w, 3), 0.3, np.float32)
        f = workres.factor_for(workres.AUTO, w, h)
        times = []
        for _ in range(a.repeats):
            t = time.perf_counter()
            field.apply(part, g, np.eye(4), P, factor=f)
            times.append(time.perf_counter() - t)
        tracemalloc.start()
        out = field.apply(part, g, np.eye(4), P, factor=f)
        peak = tracemalloc.get_traced_memory()[1]
        blended = float((lm.blend_weight(g, 1.0) > 0).mean())
        assert out is not part and blended > 0.5, blended  # the benchmark must time a blend, not the early return
        tracemalloc.stop()
        print(json.dumps(dict(size=size, factor=f, seconds=round(min(times), 4), peak_mb=round(peak / 2**20, 1),
                              blended=round(blended, 3),
                              hidden=int(field.weights[0][0].shape[0]), layers=len(field.weights) - 1)), flush=True)


if __name__ == "__main__":
    main()
