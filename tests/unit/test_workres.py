"""Prediction at a working resolution (model/infer/workres.py): the setting, the reduction that keeps
edges meaningful, the guided upsample and the wrapper around any predictor."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ssgi.model.errors import UserError
from ssgi.model.infer import workres as wr

ROOT = Path(__file__).resolve().parents[2]


def test_the_setting_reads_full_auto_a_factor_or_a_size_and_names_a_bad_value():
    assert wr.parse_setting("full") == "full" and wr.parse_setting("1x") == "full"
    assert wr.parse_setting("4x") == 4 and wr.parse_setting("1/4") == 4
    assert wr.parse_setting("480x270") == (480, 270)
    assert wr.factor_for("auto", 1920, 1080) == 4 and wr.factor_for("auto", 320, 180) == 1
    # auto: a working image 480 px wide from 960 (1/2 at 960, 1/3 at 1440, 1/8 at 3840), a one-render model 1/4
    assert [wr.factor_for("auto", w, w * 9 // 16) for w in (959, 960, 1280, 1440, 3840)] == [1, 2, 2, 3, 8]
    assert [wr.factor_for("auto", w, w * 9 // 16, one_render=True) for w in (959, 960, 1920, 3840)] == [1, 4, 4, 4]
    assert wr.factor_for("480x270", 1920, 1080) == 4 and wr.factor_for("500x300", 1920, 1080) == 4
    assert wr.factor_for("full", 1920, 1080) == 1
    for bad in ("quarter", "0x", "0x10", "-2x"):
        with pytest.raises(UserError, match="working resolution"):
            wr.parse_setting(bad)
    from ssgi.model.cliargs import ArgError, working_res
    assert working_res("480x270") == "480x270"
    with pytest.raises(ArgError, match="'quarter'"):  # argparse prints it after "argument --working-res:"
        working_res("quarter")


def test_box_reduce_averages_only_the_real_pixels_of_a_partial_border_block():
    a = np.arange(5 * 3, dtype=np.float32).reshape(5, 3)  # 5 x 3 at factor 2: blocks of 4, 2 and 1 real pixels
    r = wr.box_reduce(a, 2)
    assert r.shape == (3, 2)
    assert r[0, 0] == pytest.approx(np.mean([0, 1, 3, 4])) and r[0, 1] == pytest.approx(np.mean([2, 5]))
    assert r[2, 1] == pytest.approx(14.0)  # the corner block holds one pixel


@pytest.mark.parametrize("f", [2, 3, 4])
def test_the_fast_reduction_gives_the_bits_of_the_plain_numpy_one(f):
    """_block_sum adds slices and representative_index sorts (both faster); the result must be the bits of
    sum(axis=...) and of np.median, also for blocks of ties and of samples where nothing was hit (inf)."""
    rng = np.random.default_rng(f)
    a = (rng.exponential(1, (48, 96, 3)) * rng.choice([1e-3, 1, 1e3], (48, 96, 1))).astype(np.float32)
    plain = a.reshape(48 // f, f, 96 * 3).sum(axis=1, dtype=np.float32).reshape(48 // f, 96 // f, f, 3).sum(axis=2, dtype=np.float32)
    assert np.array_equal(wr._block_sum(a, f), plain)
    z = np.round(rng.uniform(1, 10, (55, 97, 1)) * 2).astype(np.float32) / 2  # many ties
    z[rng.random((55, 97)) < 0.3] = np.inf
    z[:12, :12] = np.inf  # whole blocks of sky
    zb = wr._blocks(wr._pad_mult(np.nan_to_num(z[..., 0], posinf=np.float32(3e38)), f), f)
    with np.errstate(over="ignore"):
        want = np.argmin(np.abs(zb - np.median(zb, axis=-1, keepdims=True)), axis=-1)
    assert np.array_equal(wr.representative_index(z, f), want)


def test_depth_and_normal_are_not_averaged_across_a_silhouette_but_taken_from_one_real_pixel():
    # a 4x4 block: 11 pixels of a wall at depth 2 facing +z, 5 of a box edge at depth 9 facing +x
    z = np.full((4, 4, 1), 2.0, np.float32)
    n = np.zeros((4, 4, 3), np.float32)
    n[..., 2] = 1
    z[0, :] = 9.0
    z[1, 0] = 9.0
    n[z[..., 0] == 9.0] = (1, 0, 0)
    alb = np.full((4, 4, 3), 0.5, np.float32)
    alb[z[..., 0] == 9.0] = 0.1
    lo = wr.reduce_groups({"depth": z, "normal": n, "albedo": alb}, 4)
    assert lo["depth"].shape == (1, 1, 1) and lo["depth"][0, 0, 0] == 2.0  # the majority surface, not 4.2
    np.testing.assert_array_equal(lo["normal"][0, 0], (0, 0, 1))  # a unit normal of that same pixel
    assert lo["albedo"][0, 0, 0] == pytest.approx((11 * 0.5 + 5 * 0.1) / 16)  # colour: the block's mean


def _scene(H=36, W=64, edge=27):
    """Two surfaces meeting at a vertical depth and normal edge at x = edge (not on a block boundary)."""
    z = np.full((H, W, 1), 3.0, np.float32)
    z[:, edge:] = 9.0
    n = np.zeros((H, W, 3), np.float32)
    n[:, :edge, 2] = 1
    n[:, edge:, 0] = 1
    return z, n


@pytest.mark.parametrize("H,W,f", [(36, 64, 4), (37, 61, 3), (20, 30, 8)])
def test_a_constant_light_comes_back_exactly_at_any_size_and_factor(H, W, f):
    z, n = _scene(H, W, edge=W // 2 + 1)
    lo = wr.reduce_groups({"depth": z, "normal": n}, f)
    light = np.full(lo["depth"].shape[:2] + (3,), 0.7, np.float32)
    for method in ("guided", "bilinear"):
        up = wr.upsample_light(light, lo, {"depth": z, "normal": n}, method=method, factor=f)
        assert up.shape == (H, W, 3)
        np.testing.assert_allclose(up, 0.7, rtol=1e-5)


def test_the_guided_upsample_keeps_a_light_step_at_a_depth_edge_that_bilinear_blurs():
    z, n = _scene()
    hi = {"depth": z, "normal": n}
    light = lambda zz: np.where(zz[..., 0] < 5, 1.0, 0.1).astype(np.float32)[..., None].repeat(3, -1)  # noqa: E731
    lo = wr.reduce_groups(hi, 4)  # each low sample holds the light of the surface it represents (as predicted)
    truth = light(z)
    err = {m: np.abs(wr.upsample_light(light(lo["depth"]), lo, hi, method=m, factor=4) - truth).max() for m in
           ("guided", "bilinear")}
    assert err["bilinear"] > 0.2  # bilinear mixes the two surfaces' light over the blocks around the edge
    assert err["guided"] < 0.01 * err["bilinear"] + 1e-3, err


def test_samples_with_black_albedo_or_no_geometry_lend_no_light_to_their_neighbours():
    H, W = 32, 32
    z, n = np.full((H, W, 1), 4.0, np.float32), np.zeros((H, W, 3), np.float32)
    n[..., 2] = 1
    alb = np.full((H, W, 3), 0.6, np.float32)
    alb[:, 16:] = 0.0  # black (or sky) on the right: part 0 there, which is no evidence of the light
    part = alb * 2.0  # the light is 2 everywhere the albedo shows it
    hi = {"depth": z, "normal": n, "albedo": alb, "part": part}
    lo = wr.reduce_groups(hi, 4)
    for m in ("guided", "bilinear"):
        out = wr.upsample_part(lo["part"], lo, hi, method=m, residual=False)
        np.testing.assert_allclose(out, part, rtol=1e-5, atol=1e-6)  # plain light / albedo would darken x=12..15


def test_a_colour_channel_with_no_albedo_takes_the_grey_light_instead_of_zero():
    light, conf = wr.diffuse_light(np.array([[[0.8, 0.0, 0.0]]], np.float32), np.array([[[0.4, 0.0, 0.0]]], np.float32))
    np.testing.assert_allclose(light[0, 0], (2.0, 2.0, 2.0))
    assert conf[0, 0] == pytest.approx(0.4 / 3)


class Analytic:
    """A predictor of the inference interface (not a model): the diffuse part albedo x (direct_soft + 0.3)."""
    target = "ref_diffuse"
    spec = required = ("albedo", "normal", "depth", "direct_soft")
    last_repaired = 0

    def __init__(self):
        self.sizes = []

    def predict(self, groups, tile=-1):
        self.sizes.append(groups["albedo"].shape[:2])
        return (groups["albedo"] * (groups["direct_soft"] + 0.3)).astype(np.float32)


def _room(H=72, W=128, seed=0):
    rng = np.random.default_rng(seed)
    z, n = _scene(H, W, edge=53)
    alb = np.where(z < 5, 0.7, 0.3).astype(np.float32).repeat(3, -1) * rng.uniform(0.8, 1.0, 3).astype(np.float32)
    soft = np.zeros((H, W, 3), np.float32)
    soft[10:40, 5:45] = 1.5  # a lit patch with hard edges inside one surface: no depth or normal edge there
    return {"depth": z, "normal": n, "albedo": alb, "direct_soft": soft}


def test_the_wrapper_runs_the_inner_predictor_at_the_working_size_and_keeps_shadow_edges_of_the_direct_light():
    g = _room()
    inner = Analytic()
    full = inner.predict(g)
    w = wr.WorkingResolution(inner, "4x", residual=True)
    assert w.target == "ref_diffuse" and w.spec == inner.spec and w.required == inner.required
    out = w.predict(g)
    assert inner.sizes[-1] == (18, 32) and out.shape == full.shape and w.last_factor == 4
    # the lit patch's edges come back sharp from the full-resolution direct light: exact here
    np.testing.assert_allclose(out, full, rtol=1e-5, atol=1e-5)
    lo = wr.reduce_groups(g, 4)
    nores = wr.upsample_part(inner.predict(lo), lo, g, residual=False)
    assert np.abs(nores - full).max() > 0.2  # without the residual the patch's edges blur over a block
    assert wr.WorkingResolution(inner, "full").predict(g) is not None and inner.sizes[-1] == (72, 128)


def test_the_shipped_model_at_a_working_resolution_stays_exact_under_tiling():
    from ssgi.model.infer.predictor import load_predictor
    from ssgi.model.dataset import synthetic

    pred = load_predictor(ROOT / "models" / "ssgi_default.pt", num_threads=1)
    g = synthetic.with_emission(synthetic.sample(256, 144, seed=3, scene_seed=4), 3)
    from ssgi.model import channels as ch
    hw = g["direct"].shape[:2]
    g = {k: v for k, v in g.items()} | {x: g.get(x, np.zeros(hw + (ch.group_size(x),), np.float32)) for x in pred.required}
    w = wr.WorkingResolution(pred, "2x")
    whole = w.predict(g, tile=None)
    tiled = w.predict(g, tile=32)  # the network runs tiled at 128 x 72
    np.testing.assert_allclose(tiled, whole, rtol=1e-4, atol=1e-5)
    assert whole.shape == (144, 256, 3) and np.isfinite(whole).all() and (whole >= 0).all()


def test_anti_aliased_sky_edge_pixels_keep_their_coverage_times_the_surface_light_not_a_dark_rim():
    # geometry on the left, sky (clip-end depth, zero normal, zero albedo) on the right; the column between
    # is half covered: EEVEE averages the albedo (0.5 x 0.6) but takes depth and normal from one sample (sky)
    H, W, L = 32, 64, 2.0
    z = np.full((H, W, 1), 4.0, np.float32)
    n = np.zeros((H, W, 3), np.float32)
    n[..., 2] = 1
    alb = np.full((H, W, 3), 0.6, np.float32)
    z[:, 29:], n[:, 29:], alb[:, 29:] = 1000.0, 0.0, 0.0
    alb[:, 29] = 0.5 * 0.6
    soft = np.zeros((H, W, 3), np.float32)

    class Light:
        target, spec, required, last_repaired = "ref_diffuse", ("albedo", "normal", "depth"), ("albedo", "normal", "depth"), 0

        def predict(self, groups, tile=-1):
            return groups["albedo"] * L

    g = {"depth": z, "normal": n, "albedo": alb, "direct_soft": soft}
    for f in (2, 4, 8):
        for method in ("guided", "bilinear"):
            out = wr.WorkingResolution(Light(), f"{f}x", method=method).predict(g)
            np.testing.assert_allclose(out[:, 29], 0.3 * L, rtol=1e-4)  # the edge column: not darker
            np.testing.assert_allclose(out[:, :29], 0.6 * L, rtol=1e-4)
            assert (out[:, 30:] == 0).all()


def test_auto_keeps_a_one_render_model_at_a_quarter_and_another_model_480_px_wide():
    g = _room(H=540, W=960)

    class OneRender(Analytic):
        spec = required = ("albedo", "normal", "depth", "direct_soft", "eevee_combined")

    g["eevee_combined"] = g["direct_soft"]
    for inner, f in ((Analytic(), 2), (OneRender(), 4)):
        w = wr.WorkingResolution(inner, "auto")
        w.predict(g)
        assert w.last_factor == f and inner.sizes[-1] == (540 // f, 960 // f)
