"""Temporal mode (model/infer/temporal.py): the Vector pass convention, the reprojection and its
validity mask, the finite-window blend (exact where there is no history) and the warped flicker measure."""
from __future__ import annotations

import numpy as np

from ssgi.model.evaluate.analysis import temporal_change
from ssgi.model.infer import temporal as tp

H, W = 12, 16


def _vec(x, y):
    v = np.zeros((H, W, 4), np.float32)
    v[..., 0], v[..., 1] = x, y
    return v


def _pattern(shift_cols=0, shift_rows=0):
    """A smooth pattern of the world seen through a camera that moved: pixel (i, j) shows world (i+sr, j+sc)."""
    i, j = np.mgrid[0:H, 0:W].astype(np.float32)
    i, j = i + shift_rows, j + shift_cols
    return np.stack([np.sin(0.4 * j) + 1.5, np.cos(0.3 * i) + 1.5, 0.1 * i + 0.05 * j + 0.2], -1).astype(np.float32)


def test_x_points_right_to_the_previous_position_and_y_points_up():
    prev = _pattern()
    cur = _pattern(shift_cols=3, shift_rows=0)  # content moved 3 px left: each pixel was 3 px to the right
    out, valid = tp.reproject(prev, _vec(3.0, 0.0))
    assert np.array_equal(out[:, :W - 3], cur[:, :W - 3]) and (valid[:, :W - 3] == 1).all()
    assert (valid[:, W - 3:] == 0).all()  # out of frame
    cur = _pattern(shift_rows=-2)  # content moved 2 rows down (towards the bottom): it was 2 rows up (+Y)
    out, valid = tp.reproject(prev, _vec(0.0, 2.0))
    assert np.allclose(out[2:], cur[2:]) and (valid[:2] == 0).all() and (valid[2:] == 1).all()
    # a half-pixel move is the bilinear mean of the two neighbours
    out, valid = tp.reproject(prev, _vec(0.5, 0.0))
    assert np.allclose(out[:, :W - 1], 0.5 * (prev[:, :W - 1] + prev[:, 1:]), atol=1e-6)


def test_the_mask_rejects_disocclusion_and_changed_normal_or_albedo():
    prev = _pattern()
    g_prev = dict(depth=np.full((H, W, 1), 2.0, np.float32), normal=np.tile([0, 0, 1.0], (H, W, 1)).astype(np.float32),
                  albedo=np.full((H, W, 3), 0.5, np.float32))
    g_cur = {k: v.copy() for k, v in g_prev.items()}
    g_cur["depth"][0:3] = 1.0  # an object in front now: disoccluded history there
    g_cur["normal"][3:5] = [1.0, 0, 0]
    g_cur["albedo"][5:7] = 0.9
    _, valid = tp.reproject(prev, _vec(0, 0), g_prev, g_cur)
    assert (valid[:7] == 0).all() and (valid[7:] == 1).all()
    g_cur["depth"][0:3] = 2.04  # a small dolly (2 %) keeps the history
    _, valid = tp.reproject(prev, _vec(0, 0), g_prev, g_cur)
    assert (valid[0:3] == 1).all()
    # the same surface under another direct light (a moving object's shadow arrived): rejected; a small change
    # (the rasterizer's sampling noise) is not; and frames without a direct light keep the old test
    g_prev["direct_light"] = np.full((H, W, 3), 2.0, np.float32)
    g_cur["direct_light"] = g_prev["direct_light"].copy()
    g_cur["direct_light"][8:10] = 0.2  # in the shadow now
    g_cur["direct_light"][10:, :, 1] = 2.2  # 10 % brighter green
    _, valid = tp.reproject(prev, _vec(0, 0), g_prev, g_cur)
    assert (valid[3:7] == 0).all() and (valid[8:10] == 0).all() and (valid[7] == 1).all() and (valid[10:] == 1).all()
    _, v2 = tp.reproject(prev, _vec(0, 0), {k: v for k, v in g_prev.items() if k != "direct_light"}, g_cur)
    assert (v2[8:10] == 1).all()
    # a history entry keeps the frame's direct light (``direct`` before ``direct_soft``) as that guide
    from ssgi.model.infer import history as hist
    e = hist.make_entry(np.ones((H, W, 3), np.float32), dict(g_cur, direct_soft=np.zeros((H, W, 3), np.float32),
                                                              direct=g_cur["direct_light"]))
    assert np.array_equal(e["direct_light"], g_cur["direct_light"].astype(np.float16).astype(np.float32))


def test_the_blend_is_the_stateless_prediction_bitwise_without_history_and_for_a_still_frame():
    rng = np.random.default_rng(0)
    part = rng.uniform(0, 2, (H, W, 3)).astype(np.float32)
    albedo = rng.uniform(0.05, 0.9, (H, W, 3)).astype(np.float32)
    light = tp.light_of(part, albedo)
    assert tp.blend(part, albedo, []) is part or np.array_equal(tp.blend(part, albedo, []), part)
    # a still frame: the history is this very light, reprojected with a zero vector
    hist = tp.reproject_window([dict(light=light, albedo=albedo)] * 2, _vec(0, 0), dict(albedo=albedo))
    assert np.array_equal(tp.blend(part, albedo, hist), part)
    # no valid pixel (cut / disocclusion everywhere)
    other = light * 3
    assert np.array_equal(tp.blend(part, albedo, [(other, np.zeros((H, W), np.float32))]), part)
    # a cut by coverage: only 10 % of the pixels have history -> unchanged
    v = np.zeros((H, W), np.float32)
    v[:1] = 1
    assert np.array_equal(tp.blend(part, albedo, [(other, v)]), part)
    # a valid history moves the light towards it by w / (1 + w), and the diffuse part is light x albedo
    out = tp.blend(part, albedo, [(other, np.ones((H, W), np.float32))], weights=[1.0], clamp=False)
    assert np.allclose(out, albedo * 2 * light, rtol=1e-5)
    # the neighbourhood clamp: a history far above the present is cut to the 3 x 3 maximum of the present light
    out = tp.blend(part, albedo, [(other, np.ones((H, W), np.float32))], weights=[1.0])
    hi = tp.neighbourhood(light)[1]
    assert np.allclose(out, albedo * 0.5 * (light + np.minimum(other, hi)), rtol=1e-5)
    assert (out < albedo * 2 * light * (1 - 1e-3)).any()


def test_the_window_chains_the_vectors_into_older_frames():
    # constant motion: every frame the content moves 2 px left; t-2 is 4 px to the right of t
    f2, f1, f0 = _pattern(0), _pattern(2), _pattern(4)  # frames t-2, t-1, t
    h1 = dict(light=f1, vector=_vec(2.0, 0))
    h2 = dict(light=f2, vector=_vec(2.0, 0))
    (l1, w1), (l2, w2) = tp.reproject_window([h1, h2], _vec(2.0, 0), {})
    assert np.allclose(l1[:, :W - 2], f0[:, :W - 2]) and np.allclose(l2[:, :W - 4], f0[:, :W - 4])
    assert (w2[:, W - 4:] == 0).all() and (w2[:, :W - 4] == 1).all()


def test_warped_change_is_zero_for_a_steady_error_under_motion_and_sees_flicker():
    frames_ref = [_pattern(shift_cols=2 * t) for t in range(5)]
    vecs = [_vec(2.0, 0)] * 5
    steady = [r * 1.2 for r in frames_ref]  # wrong, but wrong the same way on the moving surface
    assert tp.warped_change(steady, frames_ref, vecs)["change"] < 1e-6
    assert temporal_change(steady, frames_ref)["change"] > 1e-3  # the unwarped measure calls motion flicker
    rng = np.random.default_rng(1)
    noisy = [r * rng.uniform(0.9, 1.1, r.shape).astype(np.float32) for r in frames_ref]
    res = tp.warped_change(noisy, frames_ref, vecs)
    assert res["change"] > 0.01 and len(res["per_step"]) == 4 and res["pixels"][0] == H * (W - 2)


def test_the_history_cache_round_trips_an_entry_bitwise_and_survives_a_damaged_file(tmp_path):
    from ssgi.model.infer import history
    rng = np.random.default_rng(2)
    groups = dict(albedo=rng.uniform(0, 1, (H, W, 3)).astype(np.float32),
                  depth=rng.uniform(1, 9, (H, W, 1)).astype(np.float32),
                  normal=rng.normal(size=(H, W, 3)).astype(np.float32), vector=_vec(1.3, -0.2))
    part = rng.uniform(0, 1, (H, W, 3)).astype(np.float32)
    made = history.make_entry(part, groups)
    c = history.HistoryCache(tmp_path, "k1", keep=1)
    c.put(5, made)
    c.put(6, made)  # keep=1: frame 5 leaves the memory, stays on disk
    assert 5 not in c.memory and sorted(p.name for p in (tmp_path / "k1").iterdir()) == ["000005.npz", "000006.npz"]
    back = history.HistoryCache(tmp_path, "k1").get(5)  # another run reads what this one wrote
    assert set(back) == set(made) and all(np.array_equal(back[k], made[k]) for k in made)
    (tmp_path / "k1" / "000006.npz").write_bytes(b"cut short")
    assert history.HistoryCache(tmp_path, "k1").get(6) is None and not (tmp_path / "k1" / "000006.npz").exists()
    assert history.cache_key(model="a", frame_size=(1, 2)) != history.cache_key(model="b", frame_size=(1, 2))
    c.clear()
    assert not tmp_path.joinpath("k1").exists()


def test_the_report_writes_the_warped_flicker_section():
    from ssgi.model.evaluate.markdown import shot_section
    raw = {}
    m = dict(warped=0.01, warped_per_step=[0.01], unwarped=0.02, psnr=30.0, tm_psnr=35.0, s_per_frame=1.5)
    raw["temporal_shot"] = dict(shot="builtin", n_frames=24, frames=[1, 24], size=[160, 90], scored_pixel_share=0.8,
                                ref_samples=64, cycles_seed="fixed", window=2, weight=0.6,
                                methods={"SSGI temporal on": m, "Cycles 1 spp + OIDN": m | dict(warped=0.02)},
                                bar=dict(flicker_at_most_cycles_1spp=True, psnr_cost_db=0.05, psnr_cost_ok=True))
    md = "\n".join(shot_section(raw["temporal_shot"]))
    assert shot_section(None) == []
    assert "## Warped flicker: 24 frames of the shot `builtin`" in md
    assert "| SSGI temporal on | 0.0100 | 0.0200 | 30.00 | 35.00 | 1.50 |" in md and "+0.05 dB" in md
