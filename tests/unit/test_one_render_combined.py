"""(bpy-free) GI-off one-render models that read the render's Combined image (``eevee_combined``)
instead of its Diffuse Direct pass: head ``residual_combined``, target ``ref_combined``, composed as EEVEE's image +
the prediction, which is signed and comes back from the working resolution as light."""
from __future__ import annotations

import numpy as np
import pytest

from ssgi.model import channels as ch, normalize
from ssgi.model.errors import UserError

SPEC = ("albedo", "normal", "depth", "emission", "eevee_combined", "glow", "surround")


def _groups(h=16, w=24, seed=0):
    r = np.random.default_rng(seed)
    n = np.zeros((h, w, 3), np.float32)
    n[..., 2] = 1.0
    alb = r.uniform(0.1, 0.9, (h, w, 3)).astype(np.float32)
    alb[0, :4] = 0.0  # metal / sky: no diffuse colour
    return {"albedo": alb, "normal": n, "depth": r.uniform(1, 5, (h, w, 1)).astype(np.float32),
            "emission": np.zeros((h, w, 3), np.float32),
            "eevee_combined": r.uniform(0, 3, (h, w, 3)).astype(np.float32),
            "surround": np.broadcast_to(r.uniform(0, 1, 12).astype(np.float32), (h, w, 12)).copy()}


def _net(bias: float = 0.0):
    """A ref_combined network whose last conv outputs the constant ``bias`` (the head alone)."""
    import torch

    from ssgi.model.learn import network
    net = network.build(network.arch_for("unet_s", ",".join(SPEC), target=ch.COMBINED_TARGET,
                                         head="residual_combined"))
    last = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)][-1]
    with torch.no_grad():
        last.weight.zero_()
        last.bias.fill_(bias)
    return net.eval()


def _image(net, g):
    import torch
    x, _ = normalize.to_inputs(g, SPEC)
    with torch.no_grad():
        return np.expm1(net(torch.from_numpy(x).permute(2, 0, 1)[None])[0].permute(1, 2, 0).numpy())


def test_the_head_starts_from_eevees_image_keeps_it_where_the_albedo_is_black_and_never_goes_negative():
    g = _groups()
    c = g["eevee_combined"]
    assert np.allclose(_image(_net(0.0), g), c, rtol=1e-4, atol=1e-5)  # o = 0: EEVEE's GI-off image itself
    black = ~(g["albedo"] > 0).any(-1)
    for bias in (3.0, -3.0, -40.0):
        img = _image(_net(bias), g)
        assert np.allclose(img[black], c[black], rtol=1e-4, atol=1e-5)  # metal, sky: EEVEE's, whatever o
        assert (img >= 0).all() and np.isfinite(img).all()
    # the network adds light where o > 0 and takes it away where o < 0 (signed), in proportion to the albedo
    up, down = _image(_net(1.0), g), _image(_net(-1.0), g)
    lit = ~black
    assert (up[lit] > c[lit]).all() and (down[lit] < c[lit]).all()
    assert np.allclose(_image(_net(-40.0), g)[lit], 0.0, atol=1e-4)  # all of it, where the albedo is above the floor


def test_the_head_needs_albedo_and_eevee_combined_and_the_target_is_the_whole_image():
    from ssgi.model.learn import network
    with pytest.raises(UserError, match="eevee_combined"):
        network.build(network.arch_for("unet_s", "albedo,normal,depth,eevee_local", target=ch.COMBINED_TARGET,
                                       head="residual_combined"))
    g = _groups() | {"ref": np.full((16, 24, 3), 0.5, np.float32)}
    assert np.array_equal(normalize.target(g, ch.COMBINED_TARGET), g["ref"])  # the loss: the whole Cycles image
    assert ch.base_group(ch.COMBINED_TARGET) == "eevee_combined" and ch.adds_part(ch.COMBINED_TARGET)
    assert not ch.adds_rest(ch.COMBINED_TARGET)  # no rest: no Diffuse Direct pass, no reflection map
    assert ch.base_group(ch.DIFFUSE_TARGET) == "rest" and ch.base_group(ch.TARGET_GROUP) is None
    assert ch.GROUPS["eevee_combined"].blender_pass is None  # the Combined pass: always written
    assert "eevee_combined" in ch.OPTIONAL_GROUPS and "eevee_combined" in ch.INPUT_GROUPS


def _predictor(net):
    from ssgi.model.learn import checkpoint
    from ssgi.model.infer.predictor import Predictor
    return Predictor(net, checkpoint.make(net, "network"), num_threads=1, tile=None)


@pytest.mark.parametrize("setting", ["full", "2x", "4x"])
def test_the_prediction_is_the_signed_part_and_the_image_keeps_eevees_full_resolution_detail(setting):
    from ssgi.model.infer import compose, workres
    g = _groups(32, 48)
    c = g["eevee_combined"]
    c[:, 23] = 9.0  # a one-pixel bright line (a highlight, an edge): the working resolution must not blur it
    for bias, sign in ((0.0, 0), (1.0, 1), (-1.0, -1)):
        pred = workres.WorkingResolution(_predictor(_net(bias)), setting).predict(g)
        lit = (g["albedo"] > 0).all(-1)
        if sign == 0:
            assert np.abs(pred).max() < 1e-3  # nothing added: the SSGI image is EEVEE's own
        else:
            assert (np.sign(pred[lit]) == sign).mean() > 0.99  # light taken away stays negative: not clamped
        assert np.all(pred[~(g["albedo"] > 0).any(-1)] == 0)
        img = compose.compose(pred, g, ch.COMBINED_TARGET)
        assert (img >= 0).all()
        if sign == 0:
            assert np.allclose(img, c, atol=1e-3)  # the line is EEVEE's, at the output resolution


def test_the_signed_upsample_keeps_negative_light_and_the_unsigned_one_clamps_it():
    from ssgi.model.infer import workres
    g = _groups(32, 48)
    lo = workres.reduce_groups(g, 4)
    part = -0.2 * lo["albedo"]
    signed = workres.upsample_part(part, lo, g, signed=True)
    assert np.allclose(signed[(g["albedo"] > 0).all(-1)] / g["albedo"][(g["albedo"] > 0).all(-1)], -0.2, atol=0.02)
    assert (workres.upsample_part(part, lo, g) == 0).all()


def test_the_lightmap_of_a_ref_combined_model_learns_the_signed_light_and_keeps_it_signed(tmp_path):
    from ssgi.model.infer import lightmap as lm
    from ssgi.model.learn import lightmap as llm
    g = {"ref": np.full((4, 4, 3), 0.2, np.float32), "eevee_combined": np.full((4, 4, 3), 0.5, np.float32)}
    assert np.allclose(llm.view_target(g, ch.COMBINED_TARGET), -0.3)  # EEVEE brighter: the target is negative
    weights = [(np.zeros((8, 6 + 6 * 2), np.float32), np.zeros(8, np.float32)),
               (np.zeros((3, 8), np.float32), np.full(3, -0.25, np.float32))]
    field = lm.Lightmap(weights, np.zeros(3), np.ones(3), nfreq=2, lam=0.5, meta={"target": ch.COMBINED_TARGET})
    pts, nrm = np.full((5, 3), 0.5, np.float32), np.tile(np.float32([0, 0, 1]), (5, 1))
    assert field.signed and np.allclose(field.field(pts, nrm), -0.25, atol=1e-5)
    back = lm.Lightmap.load(field.save(tmp_path / "m.lightmap.npz"))
    assert back.signed and np.allclose(back.field(pts, nrm), -0.25, atol=1e-5)
    plain = lm.Lightmap(weights, np.zeros(3), np.ones(3), nfreq=2, lam=0.5, meta={"target": ch.DIFFUSE_TARGET})
    assert not plain.signed and (plain.field(pts, nrm) == 0).all()  # a diffuse light field stays >= 0


def test_a_signed_lightmap_takes_light_away_in_the_frame_at_full_and_at_the_working_resolution():
    # the field must keep its sign through the frame's light: once (Lightmap.light) clamped it at 0, so where EEVEE's
    # image was too bright (the unshadowed emitter proxy round the Cornell ball) the lightmap put light back
    from ssgi.model.infer import lightmap as lm
    weights = [(np.zeros((8, 6 + 6 * 2), np.float32), np.zeros(8, np.float32)),
               (np.zeros((3, 8), np.float32), np.full(3, -0.25, np.float32))]
    h, w = 24, 40
    g = {"albedo": np.full((h, w, 3), 0.5, np.float32), "depth": np.full((h, w, 1), 3.0, np.float32),
         "normal": np.tile(np.float32([0, 0, 1]), (h, w, 1))}
    M, P = np.eye(4), np.float64([[1.5, 0, 0, 0], [0, 2.5, 0, 0], [0, 0, -1.01, -0.2], [0, 0, -1, 0]])
    for meta, want in (({"target": ch.COMBINED_TARGET}, -0.25), ({"target": ch.DIFFUSE_TARGET}, 0.0)):
        field = lm.Lightmap(weights, np.zeros(3), np.ones(3), nfreq=2, lam=1.0, meta=meta)
        for factor in (None, 4):
            assert np.allclose(field.light(g, M, P, factor), want, atol=1e-4), (meta, factor)
        part = np.full((h, w, 3), 0.1, np.float32)  # the network's part; the lightmap replaces it (weight 1)
        out = field.apply(part, g, M, P)
        inner = out[2:-2, 2:-2]
        assert np.allclose(inner, 0.5 * want, atol=1e-4), meta


def test_a_ref_combined_model_exports_to_onnx_and_runs_there_as_in_torch(tmp_path):
    import torch

    from ssgi.model.infer import compose, export, predictor
    from ssgi.model.learn import checkpoint, network
    net = network.build(network.arch_for("unet_s", ",".join(SPEC), target=ch.COMBINED_TARGET,
                                         head="residual_combined"))
    torch.manual_seed(0)
    for p in net.parameters():
        torch.nn.init.normal_(p, std=0.05)
    checkpoint.save(tmp_path / "c.pt", checkpoint.make(net, "network"))
    res = export.export(tmp_path / "c.pt", tmp_path / "c.onnx")  # refuses a graph that differs (export.parity)
    assert res["parity"]["max_ratio"] <= 1.0
    g = _groups(32, 48)
    a = predictor.load_predictor(tmp_path / "c.pt", num_threads=1, runtime="torch")
    b = predictor.load_predictor(tmp_path / "c.onnx", num_threads=1)
    assert b.runtime == "onnx" and b.target == ch.COMBINED_TARGET
    ia, ib = (compose.compose(p.predict(g), g, ch.COMBINED_TARGET) for p in (a, b))
    assert np.allclose(ia, ib, rtol=1e-4, atol=1e-5) and not np.allclose(ia, g["eevee_combined"], atol=1e-3)


def test_the_reflection_map_corrects_a_combined_models_image_only_where_the_network_cannot():
    from ssgi.model.infer import reflmap
    from ssgi.model.learn import network
    assert reflmap.ALBEDO_FLOOR == network.ALBEDO_FLOOR  # (kept in both: reflmap runs without torch)

    class Fixed(reflmap.ReflectionMap):
        def __init__(self):
            self.lam = 1.0

        def correction(self, groups, M, P, lam=None):
            return np.full(np.shape(groups["albedo"]), 0.4, np.float32)

    alb = np.zeros((1, 4, 3), np.float32)
    alb[0, 1] = 0.025  # an anti-aliased mirror edge: half the floor
    alb[0, 2] = 0.05
    alb[0, 3] = 0.6
    c = np.full((1, 4, 3), 0.1, np.float32)
    out = Fixed().apply_combined(c, {"albedo": alb}, None, None)
    # all of it on the mirror, half on its edge, none where the network learned Cycles' reflections itself
    assert np.allclose(out[0, :, 0], [0.5, 0.3, 0.1, 0.1])


def test_the_temporal_blend_keeps_a_combined_models_negative_light():
    from ssgi.model.infer import temporal as tp
    alb = np.full((8, 8, 3), 0.5, np.float32)
    part = np.full((8, 8, 3), -0.2, np.float32)  # the model takes light away (a contact shadow EEVEE missed)
    part[:, 4:] = 0.3
    hist = [(tp.light_of(part, alb, signed=True), np.ones((8, 8), np.float32))]
    out = tp.blend(part, alb, hist, signed=True)
    assert np.allclose(out, part, atol=1e-6)  # a history equal to the present: the part bit for bit, negative kept
    older = [(np.full((8, 8, 3), -0.6, np.float32), np.ones((8, 8), np.float32))]
    mixed = tp.blend(part, alb, older, clamp=False, signed=True)
    assert (mixed[:, :4] < part[:, :4]).all()  # blended towards the darker history, below 0
    # unsigned (a diffuse-part model), the same negative part would be clamped to 0: what darkened nothing before
    assert (tp.blend(part, alb, hist)[:, :4] == 0).all()


def test_the_gloss_head_lets_metal_take_light_and_keeps_eevees_image_where_neither_albedo_nor_gloss():
    import torch

    from ssgi.model.learn import network
    spec = SPEC + ("gloss",)
    g = _groups()
    gloss = np.zeros_like(g["albedo"])
    gloss[0, :2] = (0.9, 0.7, 0.3)  # a gold metal: no diffuse colour, a glossy one
    g["gloss"] = gloss
    net = network.build(network.arch_for("unet_s", ",".join(spec), target=ch.COMBINED_TARGET,
                                         head="residual_combined_gloss"))
    last = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)][-1]

    def image(bias):
        with torch.no_grad():
            last.weight.zero_()
            last.bias.fill_(bias)
            x, _ = normalize.to_inputs(g, spec)
            return np.expm1(net.eval()(torch.from_numpy(x).permute(2, 0, 1)[None])[0].permute(1, 2, 0).numpy())

    c = g["eevee_combined"]
    assert np.allclose(image(0.0), c, rtol=1e-4, atol=1e-5)  # o = 0: EEVEE's image
    up = image(1.0)
    metal, black = np.zeros((16, 24), bool), np.zeros((16, 24), bool)
    metal[0, :2], black[0, 2:4] = True, True
    assert (up[metal] > c[metal] * 1.5).all()  # the metal takes light (residual_combined keeps it as it is)
    assert np.allclose(up[black], c[black], rtol=1e-4, atol=1e-5)  # neither albedo nor gloss: EEVEE's
    assert (up[~metal & ~black] > c[~metal & ~black]).all()
    with pytest.raises(UserError, match="gloss"):
        network.build(network.arch_for("unet_s", ",".join(SPEC), target=ch.COMBINED_TARGET,
                                       head="residual_combined_gloss"))
