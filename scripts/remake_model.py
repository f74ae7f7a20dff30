"""Remake a shipped model from its recipe: bake its training data, then train it, with the commands that
models/NAME.json records under "recipe".

    .venv/bin/python scripts/remake_model.py models/ssgi_one_render.json            # data/ and runs/remake/
    .venv/bin/python scripts/remake_model.py models/ssgi_default.json --dry-run     # print the commands only
    .venv/bin/python scripts/remake_model.py models/NAME.json --jobs 2 --data data --out runs/remake/NAME.pt

A recipe is {"bake": [ARGV, ...], "train": ARGV, "init": "REV:PATH" (optional), "note": "..."}; each ARGV is a
``cli.py`` command line as a list. ``{data}`` in it stands for --data, ``{out}`` for --out and ``{init}`` for the
starting checkpoint, which ``git show REV:PATH`` writes beside --out (the shipped models that were fine-tuned from an
earlier shipped model name it by commit: git keeps every shipped model).

Resumable: rerun the same command after a kill. A bake keeps its finished samples, each bake folder is merged
(``cli.py merge``) once all its shards are done, and the training continues from OUT.last.pt (``--resume``).
With --jobs N each bake runs as N shard processes side by side. The remade model differs from the shipped one in
its last bits (another machine, another order of float operations); its architecture, inputs and target are the
same. Ship it with scripts/ship_model.py.

--smoke N is the recipe's check at a tiny scale (N samples a bake at 48x27, one epoch; the split by scene needs
N >= 2): what the tests run.
"""
from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PY = sys.executable


def load_recipe(path) -> dict:
    """The recipe of models/NAME.json, checked for shape; a one-line SystemExit naming what is wrong."""
    path = Path(path)
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        sys.exit(f"remake_model: {path}: cannot read it as JSON ({e})")
    r = meta.get("recipe")
    if not isinstance(r, dict) or not isinstance(r.get("train"), list) or not isinstance(r.get("bake"), list):
        sys.exit(f"remake_model: {path}: has no recipe (a 'recipe' object with 'bake' and 'train' command lists)")
    for argv in r["bake"] + [r["train"]]:
        if not (isinstance(argv, list) and argv and all(isinstance(a, str) for a in argv)):
            sys.exit(f"remake_model: {path}: a recipe command is not a list of strings: {argv!r}")
    return r


def fill(argv: list[str], **subs) -> list[str]:
    """``argv`` with each ``{name}`` replaced by ``subs[name]``."""
    out = []
    for a in argv:
        for k, v in subs.items():
            a = a.replace("{" + k + "}", str(v))
        out.append(a)
    return out


def option(argv: list[str], name: str) -> str | None:
    """The value of ``name`` in ``argv`` (the last one given), or None."""
    vals = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a == name]
    return vals[-1] if vals else None


def smoke_bake(argv: list[str], n: int) -> list[str]:
    """A bake command at the smoke scale: ``n`` samples at 48x27, few samples per pixel."""
    extra = ["--count", str(n), "--size", "48x27", "--ref-samples", "2", "--eevee-samples", "1"]
    if option(argv, "--gi-samples"):
        extra += ["--gi-samples", "1"]
    return argv + extra


def smoke_train(argv: list[str]) -> list[str]:
    return argv + ["--epochs", "1", "--minutes", "5", "--crop", "16", "--batch", "2", "--crops-per-image", "1",
                   "--val-fraction", "0.34"]


def commands(recipe: dict, data: Path, out: Path, jobs: int, smoke: int = 0) -> list[tuple[str, list[list[str]]]]:
    """The steps of a remake, in order: (what, [argv, ...]) where the argvs of one step run side by side."""
    init = out.with_name(out.stem + ".init.pt")
    subs = dict(data=data, out=out, init=init)
    steps = []
    for argv in recipe["bake"]:
        argv = fill(argv, **subs)
        if smoke:
            argv = smoke_bake(argv, smoke)
        folder = option(argv, "--out")
        if jobs > 1:
            steps.append((f"bake {folder}", [[PY, "cli.py", *argv, "--shard", f"{i}/{jobs}"] for i in range(jobs)]))
            steps.append((f"merge {folder}", [[PY, "cli.py", "merge", folder]]))
        else:
            steps.append((f"bake {folder}", [[PY, "cli.py", *argv]]))
    if recipe.get("init"):
        steps.append((f"init {recipe['init']}", [["git", "show", recipe["init"]]]))
    train = fill(recipe["train"], **subs) + ["--resume"]
    steps.append((f"train {out}", [[PY, "cli.py", *(smoke_train(train) if smoke else train)]]))
    return steps


def run_step(what: str, argvs: list[list[str]], init: Path) -> None:
    print(f"remake_model: {what}", file=sys.stderr, flush=True)
    if argvs[0][0] == "git":  # the starting checkpoint, from git (kept once written)
        if init.is_file():
            return
        blob = subprocess.run(argvs[0], cwd=ROOT, capture_output=True)
        if blob.returncode:
            sys.exit(f"remake_model: {' '.join(argvs[0])}: {blob.stderr.decode(errors='replace').strip()}")
        tmp = init.with_name(init.name + ".tmp")
        tmp.write_bytes(blob.stdout)
        tmp.replace(init)
        return
    procs = [subprocess.Popen(a, cwd=ROOT) for a in argvs]
    codes = [p.wait() for p in procs]
    if any(codes):
        sys.exit(f"remake_model: {what}: exit status {codes}; rerun the same command to resume")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model_json", help="models/NAME.json (its 'recipe')")
    ap.add_argument("--data", default="data", help="parent folder of the bakes (default data, in the repository)")
    ap.add_argument("--out", default=None, help="the checkpoint to write (default runs/remake/NAME.pt)")
    ap.add_argument("--jobs", type=int, default=2, help="shard processes a bake runs side by side (default 2)")
    ap.add_argument("--dry-run", action="store_true", help="print the commands, run nothing")
    ap.add_argument("--smoke", type=int, default=0, metavar="N",
                    help="the tiny check: N samples a bake at 48x27, one epoch (default 0: the real scale)")
    a = ap.parse_args(argv)
    if a.jobs < 1:
        sys.exit(f"remake_model: --jobs {a.jobs}: give 1 or more")
    recipe = load_recipe(a.model_json)
    out = Path(a.out or ROOT / "runs" / "remake" / (Path(a.model_json).stem + ".pt")).resolve()
    data = Path(a.data) if Path(a.data).is_absolute() else ROOT / a.data
    steps = commands(recipe, data, out, a.jobs, a.smoke)
    if a.dry_run:
        for what, argvs in steps:
            for argv in argvs:
                print(shlex.join(argv) + (" > " + str(out.with_name(out.stem + ".init.pt")) if argv[0] == "git" else ""))
        return 0
    out.parent.mkdir(parents=True, exist_ok=True)
    data.mkdir(parents=True, exist_ok=True)
    for what, argvs in steps:
        run_step(what, argvs, out.with_name(out.stem + ".init.pt"))
    print(json.dumps({"ok": True, "model": str(out)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
