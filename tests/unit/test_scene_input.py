"""The 'scene' input group: whole-image statistics broadcast to every pixel, computed on the full image."""
import numpy as np
import torch

from ssgi.model import channels as ch
from ssgi.model.learn import checkpoint, network
from ssgi.model.infer import predictor
from ssgi.model import normalize
from ssgi.model.infer.bench import synthetic_groups

SPEC = ch.parse_spec("albedo,normal,depth,direct,lit,scene")


def test_scene_stats_are_the_image_means_over_geometry():
    g = synthetic_groups(40, 24, seed=5)
    g["normal"][:6] = 0.0  # a band of sky: not geometry
    x, _ = normalize.to_inputs(g, SPEC)
    sl = normalize.layout(SPEC)["scene"]
    s = x[..., sl]
    assert s.shape == (24, 40, 7)
    assert np.all(s == s[0, 0])  # the same at every pixel
    geo = np.abs(g["normal"]).sum(-1) > 0.5
    np.testing.assert_allclose(s[0, 0, :3], np.log1p(g["albedo"] * g["direct"])[geo].mean(0), rtol=1e-5)
    np.testing.assert_allclose(s[0, 0, 3:6], g["albedo"][geo].mean(0), rtol=1e-5)
    assert abs(s[0, 0, 6] - geo.mean()) < 1e-6
    # a brighter room gives a larger light statistic: the network can tell the overall light level
    g2 = dict(g, direct=g["direct"] * 4)
    assert (normalize.to_inputs(g2, SPEC)[0][0, 0, sl][:3] > s[0, 0, :3]).all()


def test_scene_input_tiled_prediction_equals_untiled():
    torch.manual_seed(0)
    net = network.build(network.arch_for("unet", SPEC)).eval()
    pred = predictor.Predictor(net, checkpoint.make(net, "network", command="test"))
    g = synthetic_groups(150, 90, seed=2)
    full = pred.predict(g, tile=None)
    tiled = pred.predict(g, tile=32)
    assert np.isfinite(full).all()
    np.testing.assert_allclose(tiled, full, rtol=1e-4, atol=1e-5)


def test_scene_group_needs_its_source_passes():
    assert set(ch.required_groups(("scene",))) == {"albedo", "direct", "normal"}
    assert ch.input_channels(SPEC) == 20
