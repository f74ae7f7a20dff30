"""Benchmark: a compiled set-up's plain render against the extension's own render of the same frame, per scene.

For each artist scene (scenes/artist.py) at --size: ``cli.py setup --compiled`` writes a copy; a plain bpy process
(nothing of SSGI imported) renders it; ``cli.py render --setup --model M --working-res full --temporal off`` renders
the original through the extension's path (its passes, the torch network in the inference contract, compose). Prints
one JSON line per scene: the largest relative difference (floor 0.01 for dark pixels, as the ONNX parity) and the
mean of each image.

    nice -n 5 .venv/bin/python benchmarks/compiled_parity.py --model M.pt [--size 320x180] [--names ...] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import _bootstrap  # noqa: F401  (the checkout as package ssgi)

ROOT = Path(__file__).resolve().parent.parent
FLOOR = 0.01


def _run(argv: list[str]) -> None:
    env = dict(os.environ, BLENDER_USER_RESOURCES=tempfile.mkdtemp(prefix="ssgi-bench-user-"))
    p = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=ROOT)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(argv[:4])} ... failed:\n{p.stderr[-3000:]}")


def _rgb(path) -> np.ndarray:
    from ssgi.model.dataset import exrio
    planes, _ = exrio.read_exr(path)
    return np.stack([planes[c] for c in "RGB"], axis=-1)


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True, help="a boxmlp checkpoint")
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--names", nargs="+", default=None, help="artist scenes (default: all five)")
    ap.add_argument("--out", default=None, help="folder for the files (default: a temporary one)")
    a = ap.parse_args(argv)
    from scenes import artist as A
    from ssgi.ssgi_addon.blender.compiled import PLAIN_RENDER

    size = tuple(int(v) for v in a.size.lower().split("x"))
    out = Path(a.out or tempfile.mkdtemp(prefix="ssgi-compiled-parity-"))
    out.mkdir(parents=True, exist_ok=True)
    cli = [sys.executable, str(ROOT / "cli.py")]
    results = []
    for name in a.names or list(A.BUILDERS):
        blend = A.save(A.build(name, size), out / f"{name}.blend")
        compiled = out / f"{name}_compiled.blend"
        _run(cli + ["setup", "--blend", str(blend), "--out", str(compiled), "--compiled", "--model", a.model])
        _run([sys.executable, "-c", PLAIN_RENDER, str(compiled), str(out / f"{name}_plain.exr")])
        _run(cli + ["render", "--blend", str(blend), "--setup", "--model", a.model, "--out",
                    str(out / f"{name}_ext.exr"), "--working-res", "full", "--temporal", "off"])
        plain, ext = _rgb(out / f"{name}_plain.exr"), _rgb(out / f"{name}_ext.exr")
        rel = np.abs(plain - ext) / np.maximum(np.abs(ext), FLOOR)
        res = dict(scene=name, size=list(size), max_rel=float(rel.max()), p999_rel=float(np.quantile(rel, 0.999)),
                   mean_plain=float(plain.mean()), mean_extension=float(ext.mean()))
        print(json.dumps(res), flush=True)
        results.append(res)
    return results


if __name__ == "__main__":
    main()
