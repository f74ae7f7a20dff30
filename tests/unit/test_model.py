"""model/: normalisation, networks, metrics, checkpoints and the predictor (bpy-free, in process, fast)."""
import math
from pathlib import Path

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ssgi.model import channels as ch
from ssgi.model.learn import checkpoint, network
from ssgi.model.infer import predictor
from ssgi.model import images, metrics, normalize
from ssgi.model.infer.bench import synthetic_groups
from ssgi.model.errors import UserError

FAST = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
floats = st.floats(allow_nan=True, allow_infinity=True, width=32)


def _net(variant, spec=ch.DEFAULT_INPUTS, seed=0, **kw):
    torch.manual_seed(seed)
    return network.build(network.arch_for(variant, spec, **kw)).eval()


def _predictor(variant, **kw):
    net = _net(variant, **kw)
    return predictor.Predictor(net, checkpoint.make(net, "network", command="test"))


# ---------------------------------------------------------------- normalisation

@FAST
@given(z=arrays(np.float32, (5, 7, 1), elements=st.floats(0.015625, 65536.0, width=32)),
       scale=st.sampled_from([1e-3, 0.5, 7.0, 1e3]))
def test_depth_normalisation_is_scale_free_and_in_unit_range(z, scale):
    a = normalize.depth_normalise(z)
    b = normalize.depth_normalise(z * np.float32(scale))
    assert a.shape == (5, 7, 1) and np.isfinite(a).all()
    assert (a >= 0).all() and (a < 1).all()
    np.testing.assert_allclose(a, b, atol=1e-5)
    # 35 pixels: the median is one of them and maps to exactly 1/2
    assert np.min(np.abs(a - 0.5)) < 1e-6


@FAST
@given(z=arrays(np.float32, (4, 6, 1), elements=floats))
def test_depth_normalisation_is_finite_for_any_depth_and_background_is_one(z):
    a = normalize.depth_normalise(z)
    assert np.isfinite(a).all() and (a >= 0).all() and (a <= 1).all()
    bg = ~images.geometry_mask(z)
    assert (a[bg] == 1).all()


def test_depth_background_from_normals_and_far_clip():
    z = np.array([[[2.0], [4.0], [100.0], [np.inf]]], np.float32)
    n = np.array([[[0, 0, 1], [0, 0, 1], [0, 0, 0], [0, 0, 0]]], np.float32)
    a = normalize.depth_normalise(z, n)[0, :, 0]
    # geometry median = 3 -> 2/5, 4/7; no-hit pixels (zero normal) -> 1
    np.testing.assert_allclose(a, [0.4, 4 / 7, 1, 1], rtol=1e-6)


@FAST
@given(data=st.data(), h=st.integers(1, 6), w=st.integers(1, 6))
def test_inputs_finite_and_repaired_pixels_counted(data, h, w):
    groups = {g: data.draw(arrays(np.float32, (h, w, ch.GROUPS[g].size), elements=floats))
              for g in ("albedo", "normal", "depth", "direct")}
    x, n = normalize.to_inputs(groups, ch.DEFAULT_INPUTS)
    assert x.shape == (h, w, 13) and x.dtype == np.float32
    assert np.isfinite(x).all()
    bad = np.zeros((h, w), bool)
    for a in groups.values():
        bad |= ~np.isfinite(a).all(axis=-1)
    assert n == int(bad.sum())


def test_repair_rule_values():
    direct = np.array([[[np.nan, np.inf, -np.inf]]], np.float32)
    rep, n = normalize.repair({"direct": direct})
    assert n == 1
    np.testing.assert_array_equal(rep["direct"][0, 0], [0, normalize.LIGHT_MAX, 0])
    x, _ = normalize.to_inputs({"albedo": np.ones((1, 1, 3), np.float32), "normal": np.zeros((1, 1, 3), np.float32),
                                "depth": np.full((1, 1, 1), np.inf, np.float32), "direct": direct}, ch.DEFAULT_INPUTS)
    lay = normalize.layout(ch.DEFAULT_INPUTS)
    assert x[0, 0, lay["depth"]][0] == 1.0  # infinite depth is background
    np.testing.assert_allclose(x[0, 0, lay["direct"]], np.log1p([0, normalize.LIGHT_MAX, 0]), rtol=1e-6)


@FAST
@given(x=arrays(np.float32, (3, 5, 13), elements=st.floats(-10, 10, width=32)))
def test_flip_negates_normal_x_and_is_an_involution(x):
    lay = normalize.layout(ch.DEFAULT_INPUTS)
    f = normalize.flip_x(x, ch.DEFAULT_INPUTS)
    nx = lay["normal"].start
    np.testing.assert_array_equal(f[:, ::-1, nx], -x[:, :, nx])
    others = [i for i in range(13) if i != nx]
    np.testing.assert_array_equal(f[:, ::-1][..., others], x[..., others])
    np.testing.assert_array_equal(normalize.flip_x(f, ch.DEFAULT_INPUTS), x)
    t = normalize.flip_x(torch.from_numpy(x).permute(2, 0, 1)[None], ch.DEFAULT_INPUTS, axis=1)
    np.testing.assert_array_equal(t[0].permute(1, 2, 0).numpy(), f)


@FAST
@given(x=arrays(np.float64, (4, 3), elements=st.floats(0, 1e6)))
def test_light_transform_and_tonemap_invert(x):
    np.testing.assert_allclose(normalize.light_inverse(normalize.light_forward(x)), x, rtol=1e-9, atol=1e-9)
    y = metrics.tonemap(x)
    assert ((y >= 0) & (y < 1)).all()
    np.testing.assert_allclose(metrics.inverse_tonemap(y), x, rtol=1e-6, atol=1e-9)


# ---------------------------------------------------------------- metrics

def test_psnr_known_values_clamp_and_pooling():
    ref = np.full((4, 5, 3), 0.5)
    assert metrics.psnr(ref + 0.1, ref) == pytest.approx(20.0)
    assert metrics.psnr(ref, ref) == math.inf
    assert metrics.psnr(np.full((2, 2, 3), 5.0), np.full((2, 2, 3), 1.0)) == math.inf  # both clamp to 1
    p = metrics.PooledPSNR()
    p.add(ref + 0.1, ref)  # MSE 1e-2
    p.add(ref + 0.01, ref)  # MSE 1e-4
    assert p.value == pytest.approx(10 * math.log10(1 / 0.00505))  # pooled MSE, not mean of PSNRs
    # tonemap: 1 -> 0.5 and 3 -> 0.75: MSE 0.0625
    assert metrics.tm_psnr(np.ones((2, 2, 3)), np.full((2, 2, 3), 3.0)) == pytest.approx(10 * math.log10(1 / 0.0625))


def test_ssim_identical_is_one_and_noise_lowers_it():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 1, (20, 30, 3))
    assert metrics.ssim(a, a) == pytest.approx(1.0)
    assert metrics.ssim(np.clip(a + rng.normal(0, 0.2, a.shape), 0, 1), a) < 0.9
    assert metrics.ssim(a[:2, :2], a[:2, :2]) == 1.0  # too small for a window: still defined


# ---------------------------------------------------------------- networks

def test_fssgi_has_238339_parameters_with_13_inputs_and_is_configurable():
    assert ch.input_channels(ch.DEFAULT_INPUTS) == 13
    assert network.count_params(_net("fssgi")) == 238_339
    # width 32, 2 + 2 layers, 10 inputs: 10*9*32+32 + 32*9*32+32 + (42*9*32+32) + (32*9*32+32) + 32*9*3+3
    n = network.count_params(_net("fssgi", spec=("albedo", "normal", "depth", "direct"), width=32, pre=2, post=2))
    assert n == (2880 + 32) + (9216 + 32) + (12096 + 32) + (9216 + 32) + (864 + 3)
    assert network.count_params(_net("unet_s")) < network.count_params(_net("unet")) < network.count_params(_net("fssgi"))


@pytest.mark.parametrize("variant", ["fssgi", "unet_s", "unet"])
def test_receptive_field_bounds_the_gradient(variant):
    """The claimed receptive field covers every input pixel that matters, and the tile overlap covers the
    farthest one on either side (stride-2 layers make the field lopsided), at every alignment."""
    net = _net(variant)
    size = 2 * net.receptive_field + 33
    for c in range(size // 2, size // 2 + 4):
        x = torch.rand(1, 13, size, size, requires_grad=True)
        net(x)[0, :, c, c].sum().backward()
        ys, xs = torch.nonzero(x.grad.abs().sum(dim=(0, 1)) > 0, as_tuple=True)
        for v in (ys, xs):
            lo, hi = int(v.min()) - c, int(v.max()) - c
            assert hi - lo + 1 <= net.receptive_field
            assert max(-lo, hi) <= network.overlap_for(net)
    assert hi - lo + 1 >= net.receptive_field - 3  # and it is not a loose overestimate


def test_residual_head_starts_from_direct_light_and_demodulates():
    net = _net("unet_s")
    with torch.no_grad():
        for p in net.out.parameters():
            p.zero_()  # o = 0: the prediction is the direct-lit image albedo * direct
    g = synthetic_groups(20, 12)
    x, _ = normalize.to_inputs(g, ch.DEFAULT_INPUTS)
    with torch.no_grad():
        lin = network.to_linear(net(torch.from_numpy(x).permute(2, 0, 1)[None]))[0].permute(1, 2, 0).numpy()
    np.testing.assert_allclose(lin, g["albedo"] * g["direct"], rtol=2e-4, atol=1e-5)


@pytest.mark.parametrize("variant", ["fssgi", "unet_s", "unet"])
def test_tiled_equals_untiled(variant):
    net = _net(variant)
    x = torch.from_numpy(normalize.to_inputs(synthetic_groups(83, 61, seed=3), ch.DEFAULT_INPUTS)[0]).permute(2, 0, 1)[None]
    with torch.inference_mode():
        full = net(x)
        tiled = predictor.tiled_forward(net, x, tile=16)
    assert tiled.shape == full.shape
    torch.testing.assert_close(tiled, full, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("hw", [(1, 1), (3, 2), (2, 3), (37, 5), (5, 61)])
def test_predictor_any_size_finite(hw):
    pred = _predictor("unet")
    g = synthetic_groups(hw[1], hw[0])
    out = pred.predict(g)
    assert out.shape == (hw[0], hw[1], 3) and out.dtype == np.float32
    assert np.isfinite(out).all() and (out >= 0).all()
    np.testing.assert_allclose(pred.predict(g, tile=2), out, rtol=1e-4, atol=1e-6)


def test_predictor_nan_inf_extreme_hdr_and_black():
    pred = _predictor("unet")
    g = synthetic_groups(40, 24)
    g["direct"][3, 4] = np.nan
    g["depth"][5, 6] = np.inf
    g["normal"][7, 8, 0] = -np.inf
    out = pred.predict(g)
    assert np.isfinite(out).all() and pred.last_repaired == 3
    g = synthetic_groups(40, 24)
    g["direct"] *= np.float32(1e5)
    out = pred.predict(g)
    assert np.isfinite(out).all()
    assert out.max() <= predictor.OUTPUT_BOUND * g["direct"].max()
    black = {k: np.zeros_like(v) for k, v in g.items()}
    assert np.abs(pred.predict(black)).max() == 0.0  # residual head: zero albedo -> zero light


# ---------------------------------------------------------------- checkpoints

def test_checkpoint_roundtrip_and_errors(tmp_path):
    net = _net("unet_s")
    p = tmp_path / "m.pt"
    checkpoint.save(p, checkpoint.make(net, "network", command="test"))
    pred = predictor.load_predictor(p)
    g = synthetic_groups(33, 17)
    ref = predictor.Predictor(net, checkpoint.make(net, "network")).predict(g)
    np.testing.assert_array_equal(pred.predict(g), ref)
    assert pred.spec == ch.DEFAULT_INPUTS

    # a group missing from the input: the message names it
    with pytest.raises(UserError, match=r"direct"):
        pred.predict({k: v for k, v in g.items() if k != "direct"})
    # not a checkpoint
    txt = tmp_path / "notes.txt"
    txt.write_text("hello")
    with pytest.raises(UserError, match=r"notes\.txt: not an SSGI model checkpoint"):
        predictor.load_predictor(txt)
    plain = tmp_path / "plain.pt"
    torch.save(net.state_dict(), plain)
    with pytest.raises(UserError, match=r"plain\.pt: not an SSGI"):
        predictor.load_predictor(plain)
    # another architecture: weights of unet_s under unet's arch
    d = checkpoint.load(p)
    d["arch"] = network.arch_for("unet")
    other = tmp_path / "other.pt"
    torch.save(d, other)
    with pytest.raises(UserError, match=r"other\.pt: weights do not match architecture 'unet'"):
        predictor.load_predictor(other)
    d["arch"] = dict(d["arch"], backbone="transformer")
    torch.save(d, other)
    with pytest.raises(UserError, match=r"other\.pt: unsupported architecture"):
        predictor.load_predictor(other)


def test_save_refuses_nan_weights_and_keeps_previous(tmp_path):
    net = _net("unet_s")
    p = tmp_path / "m.pt"
    checkpoint.save(p, checkpoint.make(net, "network"))
    before = p.read_bytes()
    with torch.no_grad():
        net.out.weight[0, 0, 0, 0] = float("nan")
    with pytest.raises(UserError, match="non-finite"):
        checkpoint.save(p, checkpoint.make(net, "network"))
    assert p.read_bytes() == before
    assert [f.name for f in tmp_path.iterdir()] == ["m.pt"]  # no temporary left


def test_bf16_path_agrees_with_fp32():
    """Reduced precision (bfloat16 convolutions) agrees with float32 on HDR inputs: PSNR >= 40 dB after the
    tonemap, and stays finite for lights of 1e5."""
    net = _net("unet")
    ck = checkpoint.make(net, "network")
    g = synthetic_groups(64, 40)
    g["direct"] *= np.float32(50)
    a = predictor.Predictor(net, ck).predict(g)
    b = predictor.Predictor(_net("unet"), ck, precision="bf16-cl").predict(g)
    assert metrics.tm_psnr(b, a) >= 40
    g["direct"] *= np.float32(2000)
    assert np.isfinite(predictor.Predictor(_net("unet"), ck, precision="bf16-cl").predict(g)).all()


def test_predictor_1921x1081_keeps_shape_and_tiles_match():
    """Odd full-HD size: the default tiling (1024 core + overlap) equals one untiled pass."""
    pred = _predictor("unet_s")
    g = synthetic_groups(1921, 1081, seed=5)
    tiled = pred.predict(g)
    assert tiled.shape == (1081, 1921, 3) and np.isfinite(tiled).all()
    np.testing.assert_allclose(pred.predict(g, tile=None), tiled, rtol=1e-4, atol=1e-5)


def test_inputs_are_configurable_and_heads_name_what_they_need():
    spec = ("albedo", "normal", "depth", "direct", "ao")
    net = _net("unet_s", spec=spec)
    assert network.in_channels(net) == 11 and tuple(net.arch["inputs"]) == spec
    pred = predictor.Predictor(net, checkpoint.make(net, "network"))
    assert pred.required == spec
    assert pred.predict(synthetic_groups(9, 7)).shape == (7, 9, 3)
    with pytest.raises(UserError, match=r"head 'residual' needs input group\(s\) albedo, direct"):
        network.build(network.arch_for("unet", ("normal", "depth")))
    with pytest.raises(UserError, match="unknown variant 'nope'"):
        network.arch_for("nope")
    with pytest.raises(UserError, match="has no setting 'depth'"):
        network.arch_for("unet", depth=3)
    assert network.count_params(_net("fssgi", spec=("normal", "depth"))) < 238_339  # the log head needs nothing


def test_peak_memory_measures_a_cold_prediction_in_a_fresh_process(tmp_path):
    """bench.peak_memory runs bench.cold_prediction in a child Python process: it returns the growth of the
    child's peak resident set and the time of its first prediction; a file that is no model gives an error
    line, never an exception."""
    from ssgi.model.infer import bench
    net = _net("unet_s")
    checkpoint.save(tmp_path / "m.pt", checkpoint.make(net, "network", command="test"))
    r = bench.peak_memory(tmp_path / "m.pt", 32, 24, threads=1, timeout=300)
    assert "error" not in r, r
    assert math.isfinite(r["peak_mb"]) and r["peak_mb"] >= 0 and r["first_ms"] > 0
    (tmp_path / "notes.txt").write_text("not a model")
    bad = bench.peak_memory(tmp_path / "notes.txt", 32, 24, timeout=300)
    assert bad["peak_mb"] is None and "notes.txt" in bad["error"]


# ---------------------------------------------------------------- datasets with and without the world group

def _strip_world(folder):
    """Make ``folder`` look like a dataset baked before the ``world`` group existed."""
    import json

    from ssgi.model.dataset import exrio
    for p in sorted(folder.glob("[0-9]*.exr")):
        planes, _ = exrio.read_exr(p)
        exrio.write_exr(p, {k: v for k, v in planes.items() if not k.startswith("world.")}, half=False)
    m = json.loads((folder / "manifest.json").read_text())
    m["channel_spec"] = [g for g in m["channel_spec"] if g["name"] != "world"]
    (folder / "manifest.json").write_text(json.dumps(m))


def test_datasets_from_before_the_world_group_still_read_verify_and_feed_training(tmp_path):
    from ssgi.model.learn import data
    from ssgi.model.dataset import folder as dataset, exrio, synthetic
    new = synthetic.make_dataset(tmp_path / "new", scenes=2, per_scene=1, w=16, h=8)
    assert "world" in dataset.stored_groups(dataset.open_folder(new))
    assert dataset.verify(new) == []
    old = synthetic.make_dataset(tmp_path / "old", scenes=2, per_scene=1, w=16, h=8)
    _strip_world(old)
    assert dataset.stored_groups(dataset.open_folder(old)) == tuple(g for g in ch.SAMPLE_GROUPS
                                                                    if g not in ch.OPTIONAL_GROUPS)
    assert dataset.verify(old) == []
    assert "world" not in exrio.read_sample(old / "000000.exr") and "world" in exrio.read_sample(new / "000000.exr")
    # the inputs without `world` load from the old dataset; asking for `world` names the file and channel
    spec = ch.parse_spec("albedo,normal,depth,direct,lit")
    assert len(data.DatasetFolder.load(old, spec).samples) == 2
    with pytest.raises(UserError, match=r"manifest\.json: this dataset was baked without the group\(s\) world"):
        data.DatasetFolder.load(old, spec + ("world",))
    with pytest.raises(UserError, match=r"000000\.exr.*world\.R"):
        exrio.read_sample(old / "000000.exr", ("world",))
    # a new dataset whose sample lost its world channels is caught by verify, naming the file
    _strip_world(new)
    m = dataset.open_folder(old)
    (new / "manifest.json").write_text(__import__("json").dumps({**m, "channel_spec": ch.describe()}))
    problems = dataset.verify(new)
    assert problems and all("world.R" in p for p in problems) and "000000.exr" in problems[0]


# ---------------------------------------------------------------- files: one atomic writer, one temp pattern, one sweeper

def test_every_writer_renames_from_the_one_temp_pattern(tmp_path, monkeypatch):
    """Every file the model side writes goes through files.atomic_write: its os.replace always moves a
    ``.FINAL.PID.tmp`` beside the final file onto the final name (a writer with its own temp name fails)."""
    import os

    from ssgi.model import files
    from ssgi.model.dataset import exrio, folder as dataset, preview, synthetic
    from ssgi.model.evaluate import record
    from ssgi.model.learn import curves
    moves = []
    real = os.replace
    monkeypatch.setattr(os, "replace", lambda a, b: (moves.append((Path(a), Path(b))), real(a, b))[1])
    d = synthetic.make_dataset(tmp_path / "ds", scenes=1, per_scene=1, w=8, h=6)
    exrio.write_sample(tmp_path / "s.exr", synthetic.sample(8, 6, 0, 0))
    dataset.write_manifest(d, dataset.open_folder(d), "manifest.shard-0-of-2.json")
    preview.preview(d, tmp_path / "sheet.png")
    net = _net("fssgi")
    checkpoint.save(tmp_path / "m.pt", checkpoint.make(net, "network", command="test"))
    images.write_png(tmp_path / "p.png", np.zeros((4, 4, 3), np.uint8))
    record.write_json(tmp_path / "r.json", {"a": math.inf})
    curves.curve_png([dict(minutes=0.1, val_psnr=20.0, val_tm_psnr=21.0)], tmp_path / "c.png")
    assert len(moves) >= 9
    for src, dst in moves:
        m = files.TEMP_RE.match(src.name)
        assert m and m.group("final") == dst.name and int(m.group("pid")) == os.getpid() and src.parent == dst.parent
    assert not [p for p in tmp_path.rglob("*") if files.TEMP_RE.match(p.name)]


def test_atomic_write_keeps_the_old_file_when_the_writer_fails(tmp_path):
    from ssgi.model import files
    p = files.write_text(tmp_path / "a.json", "old")

    def broken(tmp):
        Path(tmp).write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        files.atomic_write(p, broken)
    assert p.read_text() == "old" and sorted(x.name for x in tmp_path.iterdir()) == ["a.json"]


def test_sweep_also_removes_what_the_code_before_the_one_pattern_left(tmp_path):
    """A frame folder and a model folder that a killed run of the older code left: its render temp name
    .STEM.PID.tmp.EXT and its curve temp name .NAME.tmp.png are swept (owned by their final names); user files
    that merely look alike stay."""
    import os

    from ssgi.model import files
    left = [".ssgi_0002.424242.tmp.png", f".ssgi_0003.{os.getpid()}.tmp.exr", ".model.curve.png.tmp.png"]
    keep = ["ssgi_0002.png", "model.curve.png", ".notes.tmp.txt", ".shot.tmp.png", "a.1.tmp.png"]
    for n in left + keep:
        (tmp_path / n).write_bytes(b"")
    assert files.sweep(tmp_path, owned=lambda n: n == "ssgi_0002.png") == [".ssgi_0002.424242.tmp.png"]
    assert files.sweep(tmp_path, min_age_s=0) == []  # a live writer's (this one's), and no pid in a curve's name
    assert sorted(files.sweep(tmp_path)) == sorted(left[1:])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(keep)


def test_sweep_removes_only_temp_files_owned_and_old_of_dead_processes(tmp_path):
    import os
    import subprocess
    import sys
    import time

    from ssgi.model import files
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    names = [".000001.exr.424242.tmp", ".000002.exr.424242.tmp", ".manifest.json.7.tmp", "000001.exr",
             ".hidden", "x.tmp", f".000003.exr.{child.pid}.tmp", f".000004.exr.{os.getpid()}.tmp"]
    for n in names:
        (tmp_path / n).write_bytes(b"")
    # owned: a shard sweeps only its own names
    assert files.sweep(tmp_path, owned=lambda n: n == "000002.exr") == [".000002.exr.424242.tmp"]
    # min_age_s: the dead process's file only once old; never this process's own
    assert files.sweep(tmp_path, min_age_s=600) == []
    old = time.time() - 1200
    for n in names[:1] + names[6:]:
        os.utime(tmp_path / n, (old, old))
    swept = files.sweep(tmp_path, min_age_s=600)
    assert f".000003.exr.{child.pid}.tmp" in swept and f".000004.exr.{os.getpid()}.tmp" not in swept
    # no options: every temporary file goes, no final name, nothing outside the pattern
    files.sweep(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["000001.exr", ".hidden", "x.tmp"])
    s = files.scratch("ssgi-render", ".exr", folder=tmp_path)
    m = files.TEMP_RE.match(s.name)
    assert m and m.group("final").startswith("ssgi-render-") and m.group("final").endswith(".exr")


# ---------------------------------------------------------------- the dataset format's one owner

def test_settings_schema_writes_every_identity_key_and_one_entry_reads_folders(tmp_path):
    """model/dataset/folder.py builds the settings the baker writes: every key that decides whether samples
    may share a folder (IDENTITY_SETTINGS) is in them, and differing settings are refused; open_folder is the
    one entry for a folder (shards while a farm bake runs, scene ids for the split)."""
    import json

    from ssgi.model.dataset import folder as dataset, synthetic
    eevee = {"world": "black"}
    rooms = dataset.settings("rooms", (32, 18), 2, False, 1, diffuse_bounces=3, eevee=eevee, first_seed=5)
    scenes = dataset.settings("scenes", (32, 18), 2, True, 1, diffuse_bounces=3, eevee=eevee, scenes=["a.blend"],
                              frames=[1, 2], ref_target_db=41.0)
    for s in (rooms, scenes):
        assert set(dataset.IDENTITY_SETTINGS) - set(s) <= {"first_seed", "scenes", "frames", "room_mode"}
    artist = dataset.settings("rooms", (32, 18), 2, False, 1, diffuse_bounces=3, eevee=eevee, first_seed=5,
                              room_mode="artist")
    assert set(dataset.IDENTITY_SETTINGS) <= set(rooms) | set(scenes) | set(artist)
    assert rooms["eevee"] == eevee and scenes["cycles"]["denoiser"] == "OPENIMAGEDENOISE"
    with pytest.raises(UserError, match=r"baked with ref_samples=2 \(not ref_samples=3\)"):
        dataset.check_compatible({"settings": rooms}, dict(rooms, ref_samples=3), "here")
    # a one-render bake's render (its emitter proxies' sides) must agree too; the rest of eevee need not
    one = dict(scenes, eevee={"world": "black", "one_render": {"kind": "combined", "emitter_proxy_sides": "open"}})
    old_one = dict(scenes, eevee={"world": "black", "one_render": {"kind": "combined"}})
    with pytest.raises(UserError, match=r"eevee.one_render=\{'kind': 'combined'\} \(not"):
        dataset.check_compatible({"settings": old_one}, one, "here")
    dataset.check_compatible({"settings": one}, dict(one, eevee=dict(one["eevee"], world="grey")), "here")
    dataset.check_compatible({"settings": rooms}, dict(rooms, eevee={"world": "grey"}), "here")
    d = synthetic.make_dataset(tmp_path / "d", scenes=2, per_scene=1, w=8, h=8)
    assert dataset.sample_path(d, "000001") == d / "000001.exr" and (d / "000001.exr").is_file()
    m = dataset.open_folder(d, scenes=True)
    assert sorted(m["samples"]) == ["000000", "000001"] and dataset.manifest_sha256(d)
    # a farm bake before its merge: the shard manifests' union, only when asked for
    for i, key in enumerate(sorted(m["samples"])):
        dataset.write_manifest(d, dict(m, samples={key: m["samples"][key]}), dataset.shard_manifest_name((i, 2)))
    (d / "manifest.json").unlink()
    assert dataset.open_folder(d, shards=True)["samples"] == m["samples"]
    with pytest.raises(UserError, match=r"manifest\.json: no manifest\.json in the dataset folder"):
        dataset.open_folder(d)
    with pytest.raises(UserError, match=r"nope: dataset folder does not exist"):
        dataset.open_folder(tmp_path / "nope")
    dataset.write_manifest(d, dict(m, samples={"000000": {"seed": 1}}))
    assert dataset.open_folder(d)["samples"] == {"000000": {"seed": 1}}
    with pytest.raises(UserError, match=r"sample '000000' has no 'scene' id"):
        dataset.open_folder(d, scenes=True)
    assert json.loads((d / "manifest.json").read_text())["format_version"] == ch.FORMAT_VERSION


def test_score_is_the_one_scoring_and_pools_exactly():
    """metrics.score: PSNRs over the masked pixels, SSIM/FLIP with the reference pasted where nothing was hit;
    PooledPSNR.add_score pools bit-identically to adding the masked pixels themselves."""
    rng = np.random.default_rng(3)
    refs = [rng.uniform(0, 2, (9, 11, 3)).astype(np.float32) for _ in range(3)]
    preds = [r + rng.normal(0, 0.1, r.shape).astype(np.float32) for r in refs]
    masks = [rng.uniform(size=(9, 11)) > 0.3 for _ in refs]
    a, b = metrics.PooledPSNR(), metrics.PooledPSNR()
    ta, tb = metrics.PooledPSNR(tonemapped=True), metrics.PooledPSNR(tonemapped=True)
    for p, r, m in zip(preds, refs, masks):
        s = metrics.score(p, r, m)
        a.add_score(s)
        ta.add_score(s)
        b.add(p[m], r[m])
        tb.add(p[m], r[m])
        assert s["psnr"] == metrics.psnr(p[m], r[m]) and s["pixels"] == 3 * int(m.sum())
        pasted = np.where(m[..., None], p, r)
        assert s["ssim"] == metrics.ssim(pasted, r) and s["flip"] == metrics.flip(pasted, r)
    assert (a.value, ta.value) == (b.value, tb.value)
    assert metrics.score(preds[0], refs[0], with_flip=False, with_ssim=False)["flip"] is None


def test_one_linear_to_srgb8_rule_and_one_geometry_mask():
    """images.srgb8: Reinhard then the sRGB curve (0 -> 0, 1 -> sRGB(0.5) = 188, +Inf -> 255, NaN -> 0), and
    the float images.srgb the report draws is the same curve; images.geometry_mask: depth in (0, 1e9) and a
    normal longer than 0.5, the mask of the depth normalisation's background."""
    lin = np.array([[[0.0, 1.0, np.inf], [np.nan, -1.0, 1e9]]], np.float32)
    assert images.srgb8(lin).tolist() == [[[0, 188, 255], [0, 0, 255]]]
    assert np.array_equal(np.round(images.srgb(lin) * 255).astype(np.uint8), images.srgb8(lin))
    assert images.srgb8(np.full((1, 1, 3), 0.5, np.float32), exposure=2.0).tolist() == [[[188] * 3]]
    z = np.array([[1.0, 0.0, np.nan, 2e9, 3.0]], np.float32)[..., None]
    n = np.array([[[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, 1], [0.3, 0.3, 0.3]]], np.float32)
    assert images.geometry_mask(z).tolist() == [[True, False, False, False, True]]
    assert images.geometry_mask(z, n).tolist() == [[True, False, False, False, True]]
    n[0, 4] = [0.2, 0.2, 0.2]  # |n| = 0.35: an edge pixel that is mostly background
    assert images.geometry_mask(z, n).tolist() == [[True, False, False, False, False]]
    assert normalize.depth_normalise(z, n)[0, 4, 0] == 1.0  # background for the depth normalisation too


def test_a_group_added_to_the_spec_reaches_the_preview_the_benchmark_and_the_ablation(monkeypatch):
    """The channel spec is the one list: a new stored input group shows in the preview's columns (in its own
    style), in the benchmark's synthetic inputs and in the fit's ablation order, and its render pass is the
    one the Blender side reads."""
    from dataclasses import replace

    from ssgi.model.dataset import folder as dataset, preview
    from ssgi.model.infer import bench
    from ssgi.model.learn import ablation
    new = replace(ch.GROUPS["ao"], name="curvature", render_pass="Curvature", preview="grey", drop_rank=1)
    monkeypatch.setattr(ch, "GROUPS", {**ch.GROUPS, "curvature": new})
    monkeypatch.setattr(ch, "SAMPLE_GROUPS", ch.SAMPLE_GROUPS[:-2] + ("curvature",) + ch.SAMPLE_GROUPS[-2:])
    monkeypatch.setattr(ch, "INPUT_GROUPS", ch.INPUT_GROUPS + ("curvature",))
    m = dataset.new_manifest({}, "test")
    assert "curvature" in preview.columns(m) and preview.columns(m)[-1] == "ref"
    assert preview._tile("curvature", np.full((2, 2, 1), 0.5, np.float32)).shape == (2, 2, 3)
    assert bench.synthetic_groups(4, 3)["curvature"].shape == (3, 4, 1)
    assert ch.drop_order()[:4] == ("direct_soft", "emit_direct", "world", "curvature")
    spec = ch.parse_spec("albedo,direct,curvature")
    assert ablation.droppable(spec, "residual") == ["curvature"]
    assert {g.name: g.render_pass for g in ch.GROUPS.values()}["curvature"] == "Curvature"
