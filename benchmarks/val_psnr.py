"""Benchmark: the network-level validation metrics training reports (model/learn/validation.py evaluate: pooled
PSNR, tonemapped PSNR, SSIM over the geometry pixels) of several models on the same samples of a dataset, each
model reading its own inputs, all scored against one target group.

    .venv/bin/python benchmarks/val_psnr.py --data DIR --models a.pt b.pt [--target ref] [--split val|all]

It checks, for example, that a diffuse-part model is no worse than the shipped whole-image model on diffuse
rooms (there the diffuse part is the whole image, so one target scores both). Prints one JSON line per model.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package "ssgi")

from ssgi.model import channels as ch
from ssgi.model.dataset import folder
from ssgi.model.learn import checkpoint, data, validation


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--models", nargs="+", required=True)
    ap.add_argument("--target", default=ch.TARGET_GROUP, choices=ch.TARGETS)
    ap.add_argument("--split", default="all", choices=("val", "all"),
                    help="all samples, or the validation scenes of data.split_scenes(0.2, seed 0)")
    ap.add_argument("--per-sample", action="store_true", help="also one line per sample (its scene named)")
    ap.add_argument("--unseen", action="store_true",
                    help="leave out every scene that any of --models trained on (their checkpoints' recorded splits)")
    a = ap.parse_args(argv)
    stored = data.StoredSamples(a.data)
    keys = sorted(stored.raw)
    if a.split == "val":
        val = set(data.split_scenes(set(stored.scene.values()), 0.2, 0)[1])
        keys = [k for k in keys if stored.scene[k] in val]
    if a.unseen:
        sha, here = folder.manifest_sha256(a.data), str(Path(a.data).resolve())
        seen = set()
        for path in a.models:
            ident = checkpoint.load(path).get("dataset")
            rec = data.recorded_split(ident, sha, here) or {}
            seen |= set(rec.get("train") or ())
        keys = [k for k in keys if stored.scene[k] not in seen]
        print(json.dumps(dict(unseen_samples=len(keys), left_out_scenes=len(seen))), flush=True)
    out = []
    for path in a.models:
        ck = checkpoint.load(path)
        net = checkpoint.build_net(ck, path)
        smp = stored.samples(tuple(ck["inputs"]), keys, target=a.target)
        ev = validation.evaluate(net, smp)
        if a.per_sample:
            for sm in smp:
                one = validation.evaluate(net, [sm])
                print(json.dumps(dict(model=path, key=sm.key, scene=sm.scene, psnr=round(one["val_psnr"], 3))))
        row = dict(model=path, samples=len(keys), target=a.target, **{k: round(v, 4) for k, v in ev.items()})
        print(json.dumps(row), flush=True)
        out.append(row)
    return out


if __name__ == "__main__":
    main()
