"""model/compile/graph.py: a boxmlp network as compositor operations, evaluated with numpy, equals the extension's
own path (the inference contract around the torch network, then compose) for the same render passes."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ssgi.model.compile import graph
from ssgi.model.errors import UserError
from ssgi.model.infer.predictor import Predictor
from ssgi.model.learn import checkpoint, network


def _rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _passes(h, w, seed=0):
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(h, w, 3))
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    sky = rng.random((h, w)) < 0.15  # nothing hit: no normal, no albedo, the world's colour in the image
    n[sky] = 0.0
    alb = rng.random((h, w, 3)) * (rng.random((h, w, 1)) > 0.1)
    alb[sky] = 0.0
    img = (rng.random((h, w, 3)) ** 3 * 4.0).astype(np.float32)
    img[rng.random((h, w)) < 0.01] *= 500.0  # a few emitters
    return {"image": img, "albedo": alb.astype(np.float32), "normal": n.astype(np.float32)}


def _model(seed=0, **arch):
    torch.manual_seed(seed)
    net = network.build(network.arch_for("boxmlp", ",".join(graph.SPEC), target="ref_combined", **arch))
    with torch.no_grad():  # weights large enough that every unit and the head's both sides matter
        for p in net.parameters():
            p.mul_(3.0)
    return net, checkpoint.make(net, "network", command="test")


@pytest.mark.parametrize("size,box_passes", [((27, 48), 1), ((45, 80), 1), ((27, 48), 2)])
def test_the_numpy_graph_equals_the_contract_frame_of_the_torch_network(size, box_passes):
    net, ckpt = _model(boxes=[0, 2, 4], ref_width=48, passes=box_passes)
    passes = _passes(*size)
    rot, coef = _rotation(1), np.random.default_rng(2).normal(size=(4, 3)) * 0.3 + [[1, 1, 1], [0, 0, 0], [0, 0, 0], [0, 0, 0]]
    g = graph.from_checkpoint(ckpt, size[1])
    out = graph.evaluate(g, passes, graph.frame_params(rot, coef))
    pred = Predictor(net, ckpt, precision="fp32")
    ref = graph.contract_frame(pred, graph.contract_groups(passes, rot, coef))
    # the contract's bound (64 x the brightest input light) is not compiled: compare below it (all but a few
    # pixels of these exaggerated weights)
    groups = graph.contract_groups(passes, rot, coef)
    bound = 64.0 * max(groups["eevee_combined"].max(), groups["sky"].max())
    below = (out < 0.99 * bound).all(-1)
    assert below.mean() > 0.99
    err = np.abs(out - ref)[below] / np.maximum(np.abs(ref[below]), 0.05)
    assert err.max() < 1e-4, err.max()
    # the network changed the image (EEVEE's GI-off one), and kept it where the albedo is black
    black = ~(passes["albedo"] > 0).any(-1)
    assert np.abs(out - passes["image"])[~black].mean() > 0.05
    np.testing.assert_allclose(out[black], passes["image"][black], rtol=1e-6)
    # the boxes keep their share of a wider image: one doubling more at twice the width
    assert g.meta["boxes"] == ([0, 2, 4] if size[1] == 48 else [1, 3, 5])
    # one shared chain along x, then each box's own: (passes - 1) more along x, passes along y
    lv = g.meta["boxes"]
    assert g.count("shift") == max(lv) + (2 * box_passes - 1) * sum(lv)


def test_every_box_is_the_mean_over_its_window_with_zeros_outside():
    g = graph._Builder()
    c = g("input", "image")
    means = graph.box_means(g, c, [2])
    gr = graph.Graph(g.ops, means[0], 16, {})
    img = np.zeros((12, 16, 3), np.float32)
    img[6, 8] = 16.0 * 100.0  # one bright pixel: a 4x4 box of mean 100 around it
    out = np.expm1(graph.evaluate(gr, {"image": img}, {}))[..., 0]
    assert np.isclose(out.max(), 100.0, rtol=1e-5) and (out > 1).sum() == 16
    rows, cols = np.nonzero(out > 1)
    # the window {-1..2} of the doubling shifts +1, -2 (network.box_shift), in the compositor's directions
    assert sorted(set(rows)) == [5, 6, 7, 8] and sorted(set(cols)) == [6, 7, 8, 9], (rows, cols)
    # torch's boxes are the same windows
    x = torch.from_numpy(np.log1p(img).transpose(2, 0, 1)[None].copy())
    net = network.build(network.arch_for("boxmlp", ",".join(graph.SPEC), target="ref_combined", boxes=[2], ref_width=16))
    xin = torch.zeros(1, 12, 12, 16)
    xin[:, 6:9] = x
    tb = torch.expm1(net.box_means(xin)[0])[0, 0].numpy()
    np.testing.assert_allclose(tb, out, rtol=1e-5, atol=1e-4)


def test_a_network_of_another_variant_is_refused_in_one_line():
    net = network.build(network.arch_for("unet_s", ",".join(graph.SPEC), target="ref_combined",
                                         head="residual_combined"))
    with pytest.raises(UserError, match="does not compile into compositor nodes.*--variant boxmlp"):
        graph.from_checkpoint(checkpoint.make(net, "network", command="test"), 64, path="m.pt")
