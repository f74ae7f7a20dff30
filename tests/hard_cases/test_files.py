"""Hard case 8: broken or foreign files through the command line. Each gives exit status 2, a
message on stderr that names the file and the fault, no traceback, and leaves the would-be output as it was
(same bytes, same mtime)."""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from ssgi.model import channels as ch
from ssgi.model.learn import checkpoint, network
from ssgi.model.infer import predictor
from ssgi.model.dataset import exrio, synthetic

from ..conftest import run_cli

SENTINEL = b"an earlier result that must survive\n"


def _existing(path: Path) -> tuple[bytes, int]:
    """Put an earlier result at ``path`` with an old mtime; return what must stay."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(SENTINEL)
    os.utime(path, ns=(1_600_000_000_000_000_000, 1_600_000_000_000_000_000))
    return path.read_bytes(), path.stat().st_mtime_ns


def _user_error(p, *must: str) -> None:
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    assert "Traceback" not in p.stderr, p.stderr[-3000:]
    for m in must:
        assert m in p.stderr, (m, p.stderr[-2000:])
    assert p.stdout.strip() == "" or json.loads(p.stdout)["ok"] is False


def _untouched(path: Path, before: tuple[bytes, int]) -> None:
    assert (path.read_bytes(), path.stat().st_mtime_ns) == before, f"{path} was overwritten"
    assert [f.name for f in path.parent.iterdir() if f.name.startswith(".")] == [], "temporary files left"


@pytest.fixture(scope="module")
def template(tmp_path_factory):
    return synthetic.make_dataset(tmp_path_factory.mktemp("hard-files") / "data", scenes=2, per_scene=1, w=16,
                                  h=12, seed=3)


@pytest.fixture
def dataset(template, tmp_path):
    return Path(shutil.copytree(template, tmp_path / "data"))


def _truncate(path: Path, keep: float = 0.5) -> None:
    b = path.read_bytes()
    path.write_bytes(b[:int(len(b) * keep)])


def _rewrite(path: Path, drop=(), add=()) -> None:
    """Rewrite a sample EXR without the channels ``drop`` and with extra channels ``add``."""
    planes, _ = exrio.read_exr(path)
    for c in drop:
        del planes[c]
    for c in add:
        planes[c] = np.zeros_like(next(iter(planes.values())))
    exrio.write_exr(path, planes, half=False)


# ------------------------------------------------------------------------------------------- EXR samples

@pytest.mark.parametrize("keep", [0.5, 0.99, 0.005], ids=["half", "last-bytes", "header-only"])
def test_truncated_exr_to_predict(keep, dataset, trained, tmp_path):
    """Case 8: a truncated sample EXR passed to `cli.py predict` names the file and says it is truncated or
    unreadable; the existing output stays."""
    sample = dataset / "000001.exr"
    _truncate(sample, keep)
    out = tmp_path / "out" / "pred.exr"
    before = _existing(out)
    p = run_cli("predict", "--model", str(trained["unet_s"]), "--input", str(sample), "--out", str(out), check=False)
    _user_error(p, f"{sample}: ")
    assert "truncated or corrupt OpenEXR file" in p.stderr or "not a readable OpenEXR file" in p.stderr
    _untouched(out, before)


@pytest.mark.parametrize("fault", ["truncated", "missing", "extra"])
def test_broken_sample_in_dataset_to_train(fault, dataset, tmp_path):
    """Case 8: a dataset with a truncated sample, a sample missing a channel (direct.G), or one with a channel
    that the channel spec does not know (albedo.A): `cli.py train` names the file and the fault and leaves
    the existing model as it was."""
    sample = dataset / "000001.exr"
    if fault == "truncated":
        _truncate(sample)
        msg = "truncated or corrupt OpenEXR file"
    elif fault == "missing":
        _rewrite(sample, drop=["direct.G"])
        msg = "missing channel(s) direct.G"
    else:
        _rewrite(sample, add=["albedo.A"])
        msg = "unexpected channel(s) albedo.A"
    model = tmp_path / "models" / "m.pt"
    before = _existing(model)
    p = run_cli("train", "--data", str(dataset), "--out", str(model), "--variant", "unet_s", "--inputs", "albedo,normal,depth,direct,lit", "--epochs", "1",
                "--crop", "8", "--quiet", check=False)
    _user_error(p, f"{sample}: {msg}")
    _untouched(model, before)
    assert not checkpoint.last_path(model).exists()


def test_sample_missing_a_channel_to_predict(dataset, trained, tmp_path):
    """Case 8: `cli.py predict` on a sample that lacks a channel the model needs names the input file, the
    channel and the model."""
    sample = dataset / "000000.exr"
    _rewrite(sample, drop=["normal.Y"])
    out = tmp_path / "pred.exr"
    before = _existing(out)
    p = run_cli("predict", "--model", str(trained["unet_s"]), "--input", str(sample), "--out", str(out), check=False)
    _user_error(p, f"{sample}: missing channel(s) normal.Y", str(trained["unet_s"]))
    _untouched(out, before)


def test_manifest_of_a_newer_format(dataset, tmp_path):
    """Case 8: a manifest of a newer format version is refused by `cli.py train`, naming manifest.json and
    both versions."""
    m = json.loads((dataset / "manifest.json").read_text())
    m["format_version"] = ch.FORMAT_VERSION + 1
    (dataset / "manifest.json").write_text(json.dumps(m))
    model = tmp_path / "m.pt"
    before = _existing(model)
    p = run_cli("train", "--data", str(dataset), "--out", str(model), "--epochs", "1", "--quiet", check=False)
    _user_error(p, f"{dataset / 'manifest.json'}: manifest format_version {ch.FORMAT_VERSION + 1} is newer",
                f"({ch.FORMAT_VERSION})")
    _untouched(model, before)


# ------------------------------------------------------------------------------------------- checkpoints

def _save_raw(path: Path, ck: dict) -> Path:
    torch.save(ck, path)
    return path


def _foreign_models(src: Path, d: Path) -> dict[str, tuple[Path, str]]:
    """name -> (model file, expected fault text)."""
    ck = checkpoint.load(src)
    out = {}
    out["text"] = (d / "notes.txt", "not an SSGI model checkpoint")
    out["text"][0].write_text("a note, not a model")
    out["empty"] = (d / "empty.pt", "not an SSGI model checkpoint")
    out["empty"][0].write_bytes(b"")
    out["png"] = (d / "image.png", "not an SSGI model checkpoint")
    from PIL import Image
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(out["png"][0])
    out["state_dict"] = (_save_raw(d / "weights.pt", ck["state_dict"]), "not an SSGI model checkpoint")
    out["truncated"] = (d / "cut.pt", "not an SSGI model checkpoint")
    out["truncated"][0].write_bytes(src.read_bytes()[:2000])
    other = network.build(network.arch_for("unet", ch.DEFAULT_INPUTS))
    out["other_arch"] = (_save_raw(d / "other_arch.pt", dict(ck, arch=other.arch)),
                         "weights do not match architecture 'unet'")
    out["unknown_backbone"] = (_save_raw(d / "transformer.pt", dict(ck, arch=dict(ck["arch"], backbone="vit"))),
                               "unsupported architecture")
    out["newer_spec"] = (_save_raw(d / "spec_v9.pt", dict(ck, format_version=9)),
                         f"model was trained on channel spec v9")
    out["newer_checkpoint"] = (_save_raw(d / "ckpt_v9.pt", dict(ck, ssgi_checkpoint=9)), "SSGI checkpoint version 9")
    out["unknown_input"] = (_save_raw(d / "position.pt", dict(ck, arch=dict(ck["arch"], inputs=["position"]),
                                                               inputs=["position"])),
                            "unknown input group 'position'")
    return out


def test_foreign_and_broken_models_to_predict(dataset, trained, tmp_path):
    """Case 8: a non-checkpoint file (text, empty, PNG, a bare state_dict, a truncated checkpoint), a
    checkpoint of another architecture or an unknown backbone, of a newer channel spec or checkpoint version,
    or naming an input group this SSGI does not know: loading it is a UserError naming the model file and the
    fault, and `cli.py predict` (three of them, to keep the suite fast) exits 2 with that message."""
    from ssgi.model.errors import UserError
    models = _foreign_models(trained["unet_s"], tmp_path)
    for name, (model, fault) in models.items():
        with pytest.raises(UserError) as e:
            predictor.load_predictor(model)
        assert str(e.value).startswith(f"{model}: ") and fault in str(e.value), (name, str(e.value))
    out = tmp_path / "out" / "pred.exr"
    before = _existing(out)
    for name in ("text", "other_arch", "newer_spec"):
        model, fault = models[name]
        p = run_cli("predict", "--model", str(model), "--input", str(dataset / "000000.exr"), "--out", str(out),
                    "--json", check=False)
        _user_error(p, f"{model}: ", fault)
        _untouched(out, before)


def test_model_whose_spec_does_not_match_the_data(dataset, tmp_path):
    """Case 8: a model whose input spec needs a group the sample does not hold (ao) names the sample, the
    missing channel and the model; resuming training on a dataset other than the checkpoint's is refused,
    naming the resume file."""
    torch.manual_seed(0)
    net = network.build(network.arch_for("unet_s", ("albedo", "normal", "ao", "direct")))
    model = tmp_path / "ao.pt"
    checkpoint.save(model, checkpoint.make(net, "network", command="hard-cases"))
    sample = dataset / "000000.exr"
    _rewrite(sample, drop=["ao.Y"])
    out = tmp_path / "pred.exr"
    before = _existing(out)
    p = run_cli("predict", "--model", str(model), "--input", str(sample), "--out", str(out), check=False)
    _user_error(p, f"{sample}: missing channel(s) ao.Y", "inputs albedo,normal,ao,direct")
    _untouched(out, before)

    other = synthetic.make_dataset(tmp_path / "other", scenes=2, per_scene=1, w=16, h=12, seed=4)
    m2 = tmp_path / "m2.pt"
    run_cli("train", "--data", str(other), "--out", str(m2), "--variant", "unet_s", "--inputs", "albedo,normal,depth,direct,lit", "--epochs", "1", "--crop", "8",
            "--quiet")
    before = _existing(m2)
    last = checkpoint.last_path(m2)
    last_before = (last.read_bytes(), last.stat().st_mtime_ns)
    p = run_cli("train", "--data", str(_fresh(tmp_path)), "--out", str(m2), "--epochs", "2", "--resume", "--quiet",
                check=False)
    _user_error(p, f"{last}: was trained on another dataset")
    _untouched(m2, before)
    assert (last.read_bytes(), last.stat().st_mtime_ns) == last_before


def _fresh(tmp_path: Path) -> Path:
    return synthetic.make_dataset(tmp_path / "fresh", scenes=2, per_scene=1, w=16, h=12, seed=8)


def test_non_checkpoint_resume_file_to_train(dataset, tmp_path):
    """Case 8: `cli.py train --resume` whose MODEL.last.pt is not a checkpoint names that file; neither it
    nor MODEL is touched."""
    model = tmp_path / "m.pt"
    before = _existing(model)
    last = checkpoint.last_path(model)
    last.write_text("not a checkpoint")
    last_before = (last.read_bytes(), last.stat().st_mtime_ns)
    p = run_cli("train", "--data", str(dataset), "--out", str(model), "--epochs", "1", "--resume", "--quiet",
                check=False)
    _user_error(p, f"{last}: not an SSGI model checkpoint")
    _untouched(model, before)
    assert (last.read_bytes(), last.stat().st_mtime_ns) == last_before


# ------------------------------------------------------------------------------------------- verify

def test_verify_names_every_broken_file_and_its_fault(template, tmp_path):
    """Case 8: `cli.py verify` on a dataset with a truncated sample, a sample missing a channel, a sample with
    a channel outside the spec, a sample with NaN, and a leftover temporary file lists each file with its
    fault and exits 2 without a traceback; a manifest of a newer format is named as such."""
    d = synthetic.make_dataset(tmp_path / "d", scenes=3, per_scene=2, w=16, h=12, seed=6)
    _truncate(d / "000000.exr")
    _rewrite(d / "000001.exr", drop=["depth.Z"])
    _rewrite(d / "000002.exr", add=["position.X"])
    g = exrio.read_sample(d / "000003.exr")
    g["ref"][2, 2, 0] = np.nan
    exrio.write_sample(d / "000003.exr", g, half=False)
    (d / ".000004.exr.4242.tmp").write_bytes(b"x")
    p = run_cli("verify", str(d), check=False)
    _user_error(p, f"{d / '000000.exr'}: truncated or corrupt OpenEXR file",
                f"{d / '000001.exr'}: missing channel(s) depth.Z",
                f"{d / '000002.exr'}: unexpected channel(s) position.X",
                f"{d / '000003.exr'}: 1 non-finite value(s) in ref",
                ".000004.exr.4242.tmp", "5 problem(s) found")
    assert "000005.exr" not in p.stderr  # the good samples are not blamed
    m = json.loads((template / "manifest.json").read_text())
    m["format_version"] = ch.FORMAT_VERSION + 1
    newer = Path(shutil.copytree(template, tmp_path / "newer"))
    (newer / "manifest.json").write_text(json.dumps(m))
    p = run_cli("verify", str(newer), check=False)
    _user_error(p, f"{newer / 'manifest.json'}", f"{ch.FORMAT_VERSION + 1}")
