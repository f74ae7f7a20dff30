"""The speed-against-error report's bpy-free parts: metric functions against known values and the
equal-quality interpolation. The end-to-end runs on real Blender are tests/blender/test_report.py."""
import math

import numpy as np
import pytest

from ssgi.model import metrics
from ssgi.model.evaluate import analysis

# ------------------------------------------------------------------------------------------ metrics


def test_psnr_of_a_known_mse_pooled_over_geometry_and_scenes():
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.2, 0.8, (10, 12, 3)).astype(np.float32)
    mask = np.zeros((10, 12), bool)
    mask[:, :6] = True
    pred = ref + np.float32(0.1)  # MSE 0.01 on the scored pixels -> 20 dB
    pred[~mask] += 0.3  # outside the geometry: not scored
    a = metrics.score(pred, ref, mask)
    assert a["psnr"] == pytest.approx(20.0, abs=1e-4) and a["pixels"] == 60 * 3
    b = metrics.score(ref + np.float32(0.2), ref, mask)  # MSE 0.04 -> 13.98 dB
    assert b["psnr"] == pytest.approx(10 * math.log10(1 / 0.04), abs=1e-4)
    # tonemapped PSNR: errors measured after x / (1 + x)
    assert a["tm_psnr"] == pytest.approx(metrics.tm_psnr(pred[mask], ref[mask]), abs=1e-9) and a["tm_psnr"] > a["psnr"]
    s = analysis.summarize_method({"per_scene": {"A": dict(a, time={"whole_s": 1.0, "own_s": 0.5}),
                                            "B": dict(b, time={"whole_s": 3.0, "own_s": 1.5})}})
    assert s["psnr"] == pytest.approx(10 * math.log10(1 / 0.025), abs=1e-4)  # MSE pooled, not PSNR averaged
    assert s["worst_scene"] == "B" and s["whole_s"] == 2.0 and s["own_s"] == 1.0


def test_ssim_and_flip_of_identical_images():
    rng = np.random.default_rng(1)
    img = rng.uniform(0, 3, (24, 40, 3)).astype(np.float32)
    m = metrics.score(img, img)
    assert m["ssim"] == pytest.approx(1.0) and m["flip"] == 0.0 and m["psnr"] == math.inf


def _lab(rgb):
    """CIELAB of linear sRGB (D65 white = XYZ of RGB 1,1,1)."""
    M = np.array([[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]])
    xyz = M @ np.asarray(rgb, float) / (M @ np.ones(3))
    d = 6 / 29
    f = np.where(xyz > d ** 3, np.cbrt(xyz), xyz / (3 * d * d) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _hyab_hunt(c1, c2):
    a, b = _lab(c1), _lab(c2)
    a[1:] *= 0.01 * a[0]  # Hunt adjustment
    b[1:] *= 0.01 * b[0]
    return abs(a[0] - b[0]) + math.hypot(a[1] - b[1], a[2] - b[2])


def test_flip_of_black_against_white_matches_the_papers_formula():
    """flip-evaluator's own example images (images/reference.png, test.png: mean 0.159691) ship in neither its
    wheel nor its sdist, so the known value comes from FLIP's colour pipeline (Andersson et al. 2020): two flat
    images have no feature error, so FLIP = the colour error: HyAB distance of Hunt-adjusted L*a*b*, to the power
    0.7, mapped by c_max (green against blue), p_c = 0.4, p_t = 0.95."""
    import flip_evaluator

    cmax = _hyab_hunt([0, 1, 0], [0, 0, 1]) ** 0.7
    e = _hyab_hunt([0, 0, 0], [1, 1, 1]) ** 0.7
    pc, pt = 0.4, 0.95
    want = pt / (pc * cmax) * e if e < pc * cmax else pt + (e - pc * cmax) / (cmax - pc * cmax) * (1 - pt)
    assert want == pytest.approx(0.9674, abs=5e-4)
    black, white = np.zeros((16, 16, 3), np.float32), np.ones((16, 16, 3), np.float32)
    _, mean, _ = flip_evaluator.evaluate(black, white, "LDR", inputsRGB=False, applyMagma=False)
    assert mean == pytest.approx(want, abs=2e-4)
    # metrics.flip scores a reference with no light by LDR-FLIP: the same number
    assert metrics.flip(white, black) == pytest.approx(want, abs=2e-4)
    # HDR-FLIP grows with the error
    rng = np.random.default_rng(2)
    ref = rng.uniform(0, 2, (32, 32, 3)).astype(np.float32)
    assert 0 < metrics.flip(ref * 1.1, ref) < metrics.flip(ref * 1.5, ref)


def test_temporal_change_is_the_mean_step_of_the_tonemapped_error():
    refs = [np.zeros((4, 4, 3), np.float32)] * 3
    preds = [np.full((4, 4, 3), v, np.float32) for v in (1.0, 3.0, 1.0)]  # tonemapped errors 0.5, 0.75, 0.5
    t = analysis.temporal_change(preds, refs)
    assert t["per_step"] == pytest.approx([0.25, 0.25]) and t["change"] == pytest.approx(0.25)
    assert t["mean_abs_error"] == pytest.approx((0.5 + 0.75 + 0.5) / 3)


# ------------------------------------------------------------------------------------------ equal quality


def test_equal_quality_interpolates_log_time_on_the_ladder():
    ladder = [(1.0, 30.0), (2.0, 34.0), (3.0, 33.0), (8.0, 38.0)]  # (3 s, 33 dB) is off the upper envelope
    e = analysis.equal_quality(ladder, 32.0, 0.5)
    assert e["bound"] == "=" and e["time_s"] == pytest.approx(math.sqrt(2.0)) and e["winner"] == "method"
    assert e["speedup"] == pytest.approx(2 * math.sqrt(2.0))
    e = analysis.equal_quality(ladder, 36.0, 10.0)  # halfway (in dB) from 2 s to 8 s -> 4 s; 10 s is slower
    assert e["time_s"] == pytest.approx(4.0) and e["speedup"] == pytest.approx(0.4) and e["winner"] == "cycles_oidn"
    e = analysis.equal_quality(ladder, 20.0, 2.0)  # below the cheapest rung, and slower than it: Cycles wins
    assert (e["bound"], e["time_s"], e["winner"]) == ("<=", 1.0, "cycles_oidn")
    e = analysis.equal_quality(ladder, 20.0, 0.1)  # below the ladder but cheaper than it: no verdict
    assert (e["bound"], e["winner"]) == ("<=", "undecided")
    e = analysis.equal_quality(ladder, 40.0, 2.0)  # above the best rung and faster than it: at least 4x
    assert (e["bound"], e["speedup"], e["winner"]) == (">=", 4.0, "method")


def test_pareto_front_and_closest_rung():
    pts = [("a", 1.0, 10.0), ("b", 2.0, 12.0), ("c", 2.0, 11.0), ("d", 0.5, 5.0), ("e", 3.0, 12.0)]
    assert sorted(analysis.pareto_front(pts)) == ["a", "b", "d"]
    assert analysis.closest_rung([(1, 0.1), (2, 0.3), (4, 1.2)], 0.5)[0] == 2  # log scale: 0.5 is nearer 0.3 than 1.2
