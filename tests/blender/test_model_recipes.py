"""Each shipped model can be remade from the repository: models/NAME.json's recipe (run by
scripts/remake_model.py) is cli.py commands that this CLI accepts, with repository-relative paths only, that train
the shipped architecture; the one-render model's recipe, run at a tiny scale, bakes and trains a model of it."""
from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from ..conftest import ROOT, clean

SHIPPED = sorted(p for p in (ROOT / "models").glob("*.json") if p.with_suffix(".pt").is_file())
ARCH_KEYS = ("variant", "inputs", "target", "backbone", "widths", "convs", "head")


def recipe(path):
    return json.loads(path.read_text())["recipe"]


def parse(argv):
    """argparse's namespace of a cli.py command line; a failure names the line and argparse's message."""
    import contextlib
    import io

    import cli
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            return cli.build_parser().parse_args(argv)
    except SystemExit:
        pytest.fail(f"cli.py {' '.join(argv)}: {err.getvalue().strip()}")


def filled(argv):
    """``argv`` with its placeholders filled; {init} by a checkpoint that exists (argparse checks it does)."""
    init = str(ROOT / "models" / "ssgi_default.pt")
    return [a.replace("{data}", "data").replace("{out}", "runs/m.pt").replace("{init}", init) for a in argv]


def test_every_shipped_model_has_a_recipe():
    assert {p.stem for p in SHIPPED} >= {"ssgi_default", "ssgi_one_render", "ssgi_fit_start"}
    for p in SHIPPED:
        r = recipe(p)
        assert r["bake"] and r["train"][0] == "train" and all(b[0] == "bake" for b in r["bake"]), p.name


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_each_recipe_command_is_accepted_by_the_cli_and_names_no_machine_path(path):
    r = recipe(path)
    for argv in r["bake"] + [r["train"]]:
        text = " ".join(argv)
        assert set(re.findall(r"\{(\w+)\}", text)) <= {"data", "out", "init"}, text
        assert not [a for a in argv if a.startswith(("/", "~")) or "/tmp" in a or ".." in a], text
        parse(filled(argv))
    bakes = [parse(filled(b)) for b in r["bake"]]
    train = parse(filled(r["train"]))
    assert sorted(map(str, train.data)) == sorted(str(b.out) for b in bakes)  # trains on what it bakes, all of it


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_each_recipe_trains_the_shipped_architecture(path, tmp_path):
    """Without --init, the train command's own arch; with it, the starting checkpoint's (from git), with the
    command's --inputs where it gives them (a fine-tune may add an input group)."""
    from ssgi.model import channels as ch
    from ssgi.model.learn import checkpoint, network
    shipped = json.loads(path.read_text())["arch"]
    r = recipe(path)
    args = parse(filled(r["train"]))
    if r.get("init"):
        assert "--init" in r["train"]
        blob = subprocess.run(["git", "show", r["init"]], cwd=ROOT, capture_output=True)
        if blob.returncode and b"not a git repository" in blob.stderr:
            pytest.skip("not a git checkout")
        assert blob.returncode == 0, blob.stderr.decode()
        (tmp_path / "init.pt").write_bytes(blob.stdout)
        arch = dict(checkpoint.load(tmp_path / "init.pt")["arch"])
        if "--inputs" in r["train"]:
            arch["inputs"] = list(ch.parse_spec(args.inputs))
    else:
        arch = network.arch_for(args.variant, args.inputs, args.target, **json.loads(args.arch or "{}"))
    assert {k: arch.get(k) for k in ARCH_KEYS} == {k: shipped.get(k) for k in ARCH_KEYS}


def test_the_one_render_recipe_remakes_a_model_of_the_shipped_architecture_at_a_tiny_scale(tmp_path):
    from ssgi.model.learn import checkpoint
    path = ROOT / "models" / "ssgi_one_render.json"
    out = tmp_path / "remade.pt"
    cmd = [sys.executable, str(ROOT / "scripts" / "remake_model.py"), str(path), "--smoke", "2",
           "--data", str(tmp_path / "data"), "--out", str(out)]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=tmp_path)
    assert p.returncode == 0, clean(p.stderr)[-3000:]
    assert json.loads(p.stdout.strip().splitlines()[-1]) == {"ok": True, "model": str(out)}
    got, shipped = checkpoint.load(out)["arch"], json.loads(path.read_text())["arch"]
    assert {k: got.get(k) for k in ARCH_KEYS} == {k: shipped.get(k) for k in ARCH_KEYS}
    bakes = sorted(d.name for d in (tmp_path / "data").iterdir())
    assert len(bakes) == len(recipe(path)["bake"]) and all((tmp_path / "data" / b / "manifest.json").is_file()
                                                             for b in bakes)
