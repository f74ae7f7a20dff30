"""One-render models (bpy-free) read EEVEE's own diffuse light (``eevee_diffuse``), its
whole-image statistics (``scene_gi``) and a shading head that starts from it (``residual_gi``)."""
from __future__ import annotations

import numpy as np
import pytest

from ssgi.model import channels as ch, normalize
from ssgi.model.errors import UserError

SPEC = ("albedo", "normal", "depth", "emission", "eevee_diffuse", "scene_gi", "glow", "surround")


def _groups(h=8, w=12, seed=0):
    r = np.random.default_rng(seed)
    n = r.normal(size=(h, w, 3)).astype(np.float32)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    n[0, :3] = 0  # sky pixels: no normal
    return {"albedo": r.uniform(0.05, 0.9, (h, w, 3)).astype(np.float32), "normal": n,
            "depth": r.uniform(1, 5, (h, w, 1)).astype(np.float32),
            "emission": np.zeros((h, w, 3), np.float32),
            "eevee_diffuse": r.uniform(0, 3, (h, w, 3)).astype(np.float32),
            "direct": r.uniform(0, 3, (h, w, 3)).astype(np.float32),
            "surround": np.broadcast_to(r.uniform(0, 1, 12).astype(np.float32), (h, w, 12)).copy()}


def test_scene_gi_is_scene_computed_from_eevees_own_diffuse_light_and_commutes_with_the_flip():
    g = _groups()
    gi = normalize.derived("scene_gi", g)
    # the same statistics as "scene" with the direct light replaced by EEVEE's own diffuse light
    same = normalize.derived("scene", dict(g, direct=g["eevee_diffuse"]))
    assert gi.shape == (8, 12, 7) and np.array_equal(gi, same)
    assert not np.allclose(gi, normalize.derived("scene", g))  # not the direct light's
    flipped = {k: v[:, ::-1] for k, v in g.items()}
    assert np.array_equal(normalize.derived("scene_gi", flipped), gi)
    assert ch.required_groups(("scene_gi",)) == ("albedo", "eevee_diffuse", "normal")
    assert ch.input_channels(SPEC) == 3 + 3 + 1 + 3 + 3 + 7 + 4 + 12
    x, _ = normalize.to_inputs(g, SPEC)
    lay = normalize.layout(SPEC)
    assert np.allclose(x[..., lay["eevee_diffuse"]], np.log1p(g["eevee_diffuse"]))  # a light group: log1p


def test_the_residual_gi_head_starts_from_eevees_own_diffuse_light_and_needs_it():
    import torch

    from ssgi.model.learn import network

    net = network.build(network.arch_for("unet_s_gi", ",".join(SPEC), target="ref_diffuse"))
    last = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)][-1]
    with torch.no_grad():  # the network's own output 0: the head alone
        last.weight.zero_()
        last.bias.zero_()
    g = _groups(16, 16)
    x, _ = normalize.to_inputs(g, SPEC)
    with torch.no_grad():
        y = net(torch.from_numpy(x).permute(2, 0, 1)[None])[0].permute(1, 2, 0).numpy()
    # log1p(albedo x EEVEE's diffuse light): the diffuse part as EEVEE renders it
    assert np.allclose(np.expm1(y), g["albedo"] * g["eevee_diffuse"], rtol=1e-4, atol=1e-5)
    with pytest.raises(UserError, match="eevee_diffuse"):
        network.build(network.arch_for("unet_s_gi", "albedo,normal,depth,direct", target="ref_diffuse"))
    # the old residual head still starts from the hard direct light
    old = network.build(network.arch_for("unet_s", "albedo,normal,depth,direct,eevee_diffuse", target="ref_diffuse"))
    last = [m for m in old.modules() if isinstance(m, torch.nn.Conv2d)][-1]
    with torch.no_grad():
        last.weight.zero_()
        last.bias.zero_()
    spec2 = ("albedo", "normal", "depth", "direct", "eevee_diffuse")
    x2, _ = normalize.to_inputs(g, spec2)
    with torch.no_grad():
        y2 = old(torch.from_numpy(x2).permute(2, 0, 1)[None])[0].permute(1, 2, 0).numpy()
    assert np.allclose(np.expm1(y2), g["albedo"] * g["direct"], rtol=1e-4, atol=1e-5)


def test_eevee_diffuse_is_an_optional_stored_group_so_older_datasets_stay_whole():
    assert "eevee_diffuse" in ch.SAMPLE_GROUPS and "eevee_diffuse" in ch.OPTIONAL_GROUPS
    assert "eevee_diffuse" in ch.INPUT_GROUPS and "scene_gi" in ch.INPUT_GROUPS
    assert ch.GROUPS["eevee_diffuse"].render_pass == "Diffuse Direct"
    from ssgi.model.dataset import folder
    old = {"channel_spec": [{"name": g, "channels": []} for g in ("albedo", "normal", "world")]}
    assert "eevee_diffuse" not in folder.stored_groups(old)


# ---- GI-off one-render models: eevee_local, head residual_local, the fit's ladder and the bake's groups

LOCAL_SPEC = ("albedo", "normal", "depth", "emission", "eevee_local", "glow", "surround")


def test_the_residual_local_head_starts_from_the_gi_off_renders_diffuse_light_and_needs_it():
    import torch

    from ssgi.model.learn import ablation, network

    g = _groups(16, 16)
    g["eevee_local"] = (0.5 * g["eevee_diffuse"]).astype(np.float32)
    net = network.build(network.arch_for("unet", ",".join(LOCAL_SPEC), target="ref_diffuse", head="residual_local"))
    last = [m for m in net.modules() if isinstance(m, torch.nn.Conv2d)][-1]
    with torch.no_grad():  # the network's own output 0: the head alone
        last.weight.zero_()
        last.bias.zero_()
    x, _ = normalize.to_inputs(g, LOCAL_SPEC)
    with torch.no_grad():
        y = net(torch.from_numpy(x).permute(2, 0, 1)[None])[0].permute(1, 2, 0).numpy()
    # log1p(albedo x the GI-off render's diffuse light), not EEVEE's GI light nor the hard direct light
    assert np.allclose(np.expm1(y), g["albedo"] * g["eevee_local"], rtol=1e-4, atol=1e-5)
    with pytest.raises(UserError, match="eevee_local"):
        network.build(network.arch_for("unet", "albedo,normal,depth,eevee_diffuse", target="ref_diffuse",
                                       head="residual_local"))
    # the fit never drops what the head reads
    assert "eevee_local" not in ablation.droppable(LOCAL_SPEC, "residual_local")
    assert "eevee_local" in ch.SAMPLE_GROUPS and "eevee_local" in ch.OPTIONAL_GROUPS and "eevee_local" in ch.INPUT_GROUPS
    assert ch.GROUPS["eevee_local"].render_pass == "Diffuse Direct"


def test_scene_comb_is_the_whole_frames_light_level_from_eevees_gi_off_image():
    """A general combined model's statistics (scene_comb): mean log1p of EEVEE's GI-off Combined image itself (not
    albedo x it: it is an image already), mean albedo, the geometry fraction; mirror-invariant, as scene."""
    g = _groups()
    g["eevee_combined"] = np.random.default_rng(3).uniform(0, 2, g["albedo"].shape).astype(np.float32)
    g["normal"][:2] = 0.0  # two rows of sky: not geometry
    sc = normalize.derived("scene_comb", g)
    geo = np.abs(g["normal"]).sum(-1) > 0.5
    assert sc.shape == (8, 12, 7)
    assert np.allclose(sc[0, 0, :3], np.log1p(g["eevee_combined"][geo]).mean(0), atol=1e-6)
    assert np.allclose(sc[0, 0, 3:6], g["albedo"][geo].mean(0), atol=1e-6)
    assert sc[0, 0, 6] == np.float32(geo.mean())
    # twice the light, a higher level; the albedo's statistics unchanged
    brighter = normalize.derived("scene_comb", dict(g, eevee_combined=2 * g["eevee_combined"]))
    assert (brighter[0, 0, :3] > sc[0, 0, :3]).all() and np.array_equal(brighter[0, 0, 3:], sc[0, 0, 3:])
    flipped = {k: v[:, ::-1] for k, v in g.items()}
    assert np.array_equal(normalize.derived("scene_comb", flipped), sc)
    assert ch.required_groups(("scene_comb",)) == ("albedo", "eevee_combined", "normal")
