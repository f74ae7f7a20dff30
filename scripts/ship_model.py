"""Copy a trained checkpoint to models/ssgi_default.pt and write its metadata (models/ssgi_default.json).

    .venv/bin/python scripts/ship_model.py CHECKPOINT --bake-command "..." [--extra-json FILE]

The JSON holds the channel spec, normalisation, architecture, metrics history and best epoch, the dataset's
identity and split, and the exact commands that baked the data and trained the weights.
"""
import argparse
import json
import shutil
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parent.parent
ap = argparse.ArgumentParser()
ap.add_argument("checkpoint")
ap.add_argument("--bake-command", required=True)
ap.add_argument("--bake-commit", required=True)
ap.add_argument("--out", default=str(ROOT / "models" / "ssgi_default.pt"))
ap.add_argument("--train-command", default=None,
                help="the whole training command line(s), when the checkpoint's own (the last run's) is not all")
a = ap.parse_args()
ck = torch.load(a.checkpoint, map_location="cpu", weights_only=True)
for key in ("arch", "inputs", "channel_spec", "normalization", "history", "best", "dataset", "command"):
    if key not in ck:
        sys.exit(f"{a.checkpoint}: checkpoint lacks {key!r}")
out = Path(a.out)
shutil.copyfile(a.checkpoint, out)
meta = {
    "model": out.name,
    "bytes": out.stat().st_size,
    "params": ck.get("params"),
    "receptive_field": ck.get("receptive_field"),
    "arch": ck["arch"],
    "inputs": ck["inputs"],
    "channel_spec": ck["channel_spec"],
    "normalization": ck["normalization"],
    "best": ck["best"],
    "history": ck["history"],
    "dataset": {k: v for k, v in ck["dataset"].items() if k != "split"},
    "split": ck["dataset"].get("split"),
    "bake_command": a.bake_command,
    "bake_commit": a.bake_commit,
    "train_command": a.train_command or ck["command"],
    "last_run_command": ck["command"],
    "versions": ck.get("versions"),
    "created": ck.get("created"),
}
out.with_suffix(".json").write_text(json.dumps(meta, indent=1, default=str))
print(f"shipped {out} ({meta['bytes']} bytes), val PSNR {ck['best'].get('val_psnr'):.2f} dB")
# the ONNX export beside it: the node renders it without torch; tests check it is the reproducible
# export of this very .pt
sys.path.insert(0, str(ROOT))
import cli  # noqa: E402

cli.load_package()
from ssgi.model.infer import export  # noqa: E402

res = export.export(out, out.with_suffix(".onnx"), command=f".venv/bin/python cli.py export --model models/{out.name}")
print(f"exported {res['out'] if 'out' in res else out.with_suffix('.onnx')} (parity max rel {res['parity']['max_rel']:.1e})")
