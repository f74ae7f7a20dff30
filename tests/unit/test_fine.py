"""Near emitters the working resolution runs the network at the output resolution (model/infer/fine.py):
the boxes, the plan, crops that see the whole image's statistics, and the blend."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ssgi.model import channels as ch
from ssgi.model import normalize
from ssgi.model.infer import fine
from ssgi.model.infer import workres as wr

ROOT = Path(__file__).resolve().parents[2]


def test_boxes_cut_separate_objects_apart_and_keep_one_object_whole():
    m = np.zeros((12, 20), bool)
    assert fine.boxes(m) == []
    m[1:3, 2:5] = True  # an object ...
    m[8:11, 14:18] = True  # ... another, apart in rows and columns
    m[2:6, 4] = True  # an L joined to the first
    assert fine.boxes(m) == [(1, 6, 2, 5), (8, 11, 14, 18)]
    m2 = np.zeros((6, 6), bool)
    m2[0, 0] = m2[5, 5] = m2[0, 5] = True  # three corners: row cut, then a column cut of the top row
    assert fine.boxes(m2) == [(0, 1, 0, 1), (0, 1, 5, 6), (5, 6, 5, 6)]


@pytest.fixture
def no_cap(monkeypatch):  # these images are small: their crops hold more pixels than the working resolution
    monkeypatch.setattr(fine, "FINE_MAX_SHARE", 100.0)


def test_the_plan_crops_the_blocks_near_each_emitter_with_context_and_refuses_too_many(monkeypatch):
    monkeypatch.setattr(fine, "FINE_MAX_SHARE", 100.0)
    monkeypatch.setattr(fine, "FINE_REACH", 4)
    H, W, f = 96, 192, 4
    em = np.zeros((H, W, 3), np.float32)
    em[40:43, 45:47] = 5.0  # an emitter in blocks (10, 11)
    em[40:42, 170:172] = 2.0  # another, apart, in block (10, 42)
    hot, plan = fine.fine_plan(em, f, overlap=8, multiple=4)
    assert hot.sum() == 10
    reach = 4  # blocks
    (wy, wx, cy, cx), (wy2, wx2, cy2, cx2) = plan
    assert (cy.start, cy.stop, cx.start, cx.stop) == ((10 - reach) * f, (11 + reach) * f, (11 - reach) * f, (12 + reach) * f)
    ctx = max(8, reach * f)  # at least the reach: every emitter pixel near the core is in the window
    assert (wy.start, wy.stop, wx.start, wx.stop) == (cy.start - ctx, cy.stop + ctx, cx.start - ctx, cx.stop + ctx)
    assert (cy2.start, cy2.stop, cx2.start, cx2.stop) == (24, 60, 152, 188) and (wx2.stop, wy2.start) == (192, 8)  # clipped
    assert fine.fine_plan(np.zeros((H, W, 3), np.float32), f, 8) is None  # no emitter: nothing to run
    px = sum((a.stop - a.start) * (b.stop - b.start) for a, b, _, _ in plan)
    monkeypatch.setattr(fine, "FINE_MAX_SHARE", px / (H * W / f ** 2) - 1e-3)  # more crop pixels than allowed
    assert fine.fine_plan(em, f, 8) is None


def test_the_weight_is_one_on_the_emitter_and_falls_smoothly_with_the_distance_to_its_outline(monkeypatch):
    monkeypatch.setattr(fine, "FINE_REACH", 4)
    hot = np.zeros((40, 70), bool)
    hot[18:21, 10:40] = True
    w = fine.fine_weight(hot, 4)  # falls to 0 over 16 px
    assert (w[hot] == 1).all() and 0.9 < w[17, 25] < 1 and 0.9 < w[17, 9] < 1  # Chebyshev: the corners too
    assert w[18 - 16, 25] == 0 and w[20, 39 + 16] == 0 and (w[:, 56:] == 0).all()
    col = w[:18, 25][::-1]  # moving away from the emitter upwards
    assert (np.diff(col) < 0)[:15].all() and w[18 - 8, 25] == pytest.approx(0.5)  # half way: a half share
    assert np.abs(np.diff(col)).max() < 0.1  # no step
    np.testing.assert_array_equal(w[:, 25], w[:, 20])  # along the emitter's side: the same (its outline, not blocks)


def _one_render_groups(W=192, H=112, seed=3):
    from ssgi.model.dataset import synthetic
    g = synthetic.with_emission(synthetic.sample(W, H, seed=seed, scene_seed=4), 3)
    em = np.zeros((H, W, 3), np.float32)
    em[40:52, 90:130] = 12.0  # a bright panel
    g["albedo"][40:52, 90:130] = 0.05
    g["emission"] = em
    g["eevee_combined"] = (g["albedo"] * g["direct"] + em).astype(np.float32)
    g["surround"] = np.zeros((H, W, 12), np.float32)
    g["sky"] = np.zeros((H, W, 3), np.float32)
    return g


def test_a_crop_given_the_whole_images_statistics_gets_the_whole_images_input_there():
    g = _one_render_groups()
    spec = ("albedo", "normal", "depth", "emission", "eevee_combined", "scene_comb", "glow", "surround", "sky")
    whole, _ = normalize.to_inputs(g, spec)
    crop = {k: v[10:70, 20:150] for k, v in g.items()}
    own, _ = normalize.to_inputs(crop, spec)
    given, _ = normalize.to_inputs(crop, spec, normalize.image_stats(g, spec))
    np.testing.assert_array_equal(given, whole[10:70, 20:150])
    assert not np.array_equal(own, whole[10:70, 20:150])  # its own statistics differ: the stats matter
    assert ch.input_channels(spec) == whole.shape[-1]


def test_near_an_emitter_the_working_resolution_blends_in_the_full_resolution_prediction(no_cap):
    from ssgi.model.infer.predictor import load_predictor
    pred = load_predictor(ROOT / "models" / "ssgi_one_render.pt", num_threads=1)
    g = _one_render_groups()
    out = wr.WorkingResolution(pred, "4x").predict(g)
    plain = wr.WorkingResolution(pred, "4x", fine=False).predict(g)
    lo = wr.reduce_groups(g, 4)
    full = pred.predict(g, stats=normalize.image_stats(lo, tuple(pred.spec)))  # the whole image, not crops
    hot, plan = fine.fine_plan(g["emission"], 4, pred.overlap, pred.multiple)
    w = fine.fine_weight(hot, 4)[..., None]
    # everywhere: the upsampled prediction, and near the emitter the full-resolution one in the weight's share
    # (so each crop's context is enough: its pixels are the whole image's)
    np.testing.assert_allclose(out, plain + w * (full - plain), rtol=1e-4, atol=1e-5)
    near = (w[..., 0] > 0.9) & (g["emission"].max(-1) == 0)
    assert near.sum() > 300 and (w == 0).sum() > 10000
    assert np.abs(full - plain)[near].max() > 0.01  # the two differ beside the panel: the blend matters there
    assert wr.WorkingResolution(pred, "4x").predict({**g, "emission": np.zeros_like(g["emission"])}) is not None


def test_the_fine_pass_stays_exact_under_tiling(no_cap):
    from ssgi.model.infer.predictor import load_predictor
    pred = load_predictor(ROOT / "models" / "ssgi_one_render.pt", num_threads=1)
    g = _one_render_groups(W=256, H=144)
    w = wr.WorkingResolution(pred, "2x")
    whole = w.predict(g, tile=None)
    assert w.last_fine_pixels > 0
    np.testing.assert_allclose(w.predict(g, tile=32), whole, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("size", [(100, 61), (97, 64)])
def test_the_plan_covers_partial_border_blocks(size, no_cap):
    W, H = size
    em = np.zeros((H, W), np.float32)
    em[H - 1, W - 1] = 3.0  # the bottom-right pixel, in a partial block
    hot, plan = fine.fine_plan(em, 4, overlap=8)
    (wy, wx, cy, cx), = plan
    assert cy.stop == H and cx.stop == W and wy.stop == H and wx.stop == W
    assert fine.fine_weight(hot, 4)[H - 1, W - 1] == 1 and fine.fine_weight(hot, 4)[H - 2, W - 2] > 0.9


def test_the_input_reports_the_whole_image_values_it_used_and_the_edge_padding_is_np_pads():
    from ssgi.model.infer import contract
    g = _one_render_groups(W=97, H=61)
    spec = ("albedo", "normal", "depth", "emission", "eevee_combined", "scene_comb", "glow", "surround", "sky")
    x, _, used = normalize.inputs_and_stats(g, spec)
    want = normalize.image_stats(g, spec)
    assert set(used) == set(want) == {"scene_comb", "glow", "depth_median"}
    for k in want:
        np.testing.assert_array_equal(used[k], want[k])
    np.testing.assert_array_equal(x, normalize.to_inputs(g, spec)[0])
    seen = []

    def forward(a):
        seen.append(np.array(a))
        return np.zeros((1, 3) + a.shape[-2:], np.float32)

    xv = x.transpose(2, 0, 1)[None]  # the predictor's channels-last view
    contract.run_tiled(forward, xv, None, 4, 0)
    np.testing.assert_array_equal(seen[0], np.pad(xv, ((0, 0), (0, 0), (0, 3), (0, 3)), mode="edge"))


def test_the_predictor_keeps_the_values_its_last_input_used():
    from ssgi.model.infer.predictor import load_predictor
    pred = load_predictor(ROOT / "models" / "ssgi_one_render.pt", num_threads=1)
    g = _one_render_groups()
    pred.predict(g)
    want = normalize.image_stats(g, tuple(pred.spec))
    assert all(np.array_equal(pred.last_stats[k], want[k]) for k in want)
    crop = {k: v[:40, :60] for k, v in g.items()}
    pred.predict(crop, stats=want)  # a crop given the frame's: those are what it used
    own = normalize.image_stats(crop, tuple(pred.spec))
    assert all(np.array_equal(pred.last_stats[k], want[k]) for k in want)
    assert not np.array_equal(own["scene_comb"], want["scene_comb"])  # (the crop's own differ)
