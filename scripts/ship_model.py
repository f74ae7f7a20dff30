"""Copy a trained checkpoint to models/NAME.pt and write its metadata (models/NAME.json) and its ONNX export.

    .venv/bin/python scripts/ship_model.py CHECKPOINT --recipe RECIPE.json --bake-commit REV [--out models/NAME.pt]

The JSON holds the channel spec, normalisation, architecture, metrics history and best epoch, the dataset's
identity and split, and the recipe: the cli.py commands that bake the data and train the weights, which
scripts/remake_model.py runs. RECIPE.json is a recipe object or a model JSON that holds one (e.g. the
models/NAME.json of the model that a remake replaces).
"""
import argparse
import json
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parent.parent
ap = argparse.ArgumentParser()
ap.add_argument("checkpoint")
ap.add_argument("--recipe", required=True, help="a recipe JSON, or a model JSON holding one under 'recipe'")
ap.add_argument("--bake-commit", required=True, help="the commit whose baker made the training data")
ap.add_argument("--out", default=str(ROOT / "models" / "ssgi_default.pt"))
a = ap.parse_args()
recipe = json.loads(Path(a.recipe).read_text())
recipe = recipe.get("recipe", recipe)
if not (isinstance(recipe.get("bake"), list) and isinstance(recipe.get("train"), list)):
    sys.exit(f"{a.recipe}: not a recipe (an object with 'bake' and 'train' command lists)")
ck = torch.load(a.checkpoint, map_location="cpu", weights_only=True)
for key in ("arch", "inputs", "channel_spec", "normalization", "history", "best", "dataset", "command"):
    if key not in ck:
        sys.exit(f"{a.checkpoint}: checkpoint lacks {key!r}")


def relative(v):
    """``v`` with the checkout's own path taken out of every string (a model's metadata names no machine's folders)."""
    if isinstance(v, dict):
        return {k: relative(x) for k, x in v.items()}
    if isinstance(v, list):
        return [relative(x) for x in v]
    return v.replace(str(ROOT) + "/", "") if isinstance(v, str) else v


# the checkpoint as trained, its command and dataset naming folders relative to the checkout
ck.update({k: relative(ck[k]) for k in ("command", "dataset")})
out = Path(a.out)
torch.save(ck, out)
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
    "recipe": recipe,
    "bake_commit": a.bake_commit,
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
