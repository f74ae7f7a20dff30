"""Hard case 3: depth extremes on real EEVEE renders (64x36, 1 sample, one subprocess).

A wall 4 m in front of the camera fills the lower part of the frame, a cube stands before it, a small card
hangs 5 mm in front of the lens, and the sky above the wall is empty (no geometry). Rendered
with a perspective camera clipped 0.001 .. 1e5, an orthographic camera clipped 0.001 .. 1e5, and a
perspective camera clipped 0.1 .. 100; then through the SSGI render path (orthographic, then perspective
0.001 .. 1e5) with a model whose inputs hold depth but no normal."""
from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from ssgi.model import channels as ch
from ssgi.model.learn import checkpoint, network
from ssgi.model.infer import predictor
from ssgi.model import normalize

from ..conftest import run_py

W, H = 64, 36
NO_NORMAL = ("albedo", "depth", "direct", "lit")

RENDER = '''
import json, math, sys
import bpy, numpy as np
import ssgi
from ssgi.ssgi_addon.blender import passes
from ssgi.ssgi_addon.pipeline import render as R
from ssgi.ssgi_addon.blender.compositor import setup_scene
out_dir, model = sys.argv[1], sys.argv[2]
bpy.ops.wm.read_factory_settings(use_empty=True)
ssgi.register()
sc = bpy.context.scene
passes.set_resolution(sc, 64, 36)
sc.eevee.taa_render_samples = 1
bpy.ops.mesh.primitive_plane_add(size=1, location=(0, 4, -0.5), rotation=(math.pi / 2, 0, 0))
bpy.context.object.scale = (20, 1.2, 1)
bpy.ops.mesh.primitive_cube_add(size=0.6, location=(0.6, 2.0, -0.3))
# a 0.4 mm card 5 mm in front of the lens, left of centre in the sky of the perspective view (~7 px wide)
bpy.ops.mesh.primitive_plane_add(size=0.0004, location=(-0.0012, 0.005, 0.0003), rotation=(math.pi / 2, 0, 0))
bpy.ops.object.light_add(type="POINT", location=(0, 0, 1.5))
bpy.context.object.data.energy = 200
bpy.ops.object.camera_add(location=(0, 0, 0), rotation=(math.radians(90), 0, 0))
cam = bpy.context.object
sc.camera = cam
cam.data.ortho_scale = 4.0
meta = {}
for name, typ, cs, ce in (("persp_1e5", "PERSP", 0.001, 1e5), ("ortho_1e5", "ORTHO", 0.001, 1e5),
                          ("persp_100", "PERSP", 0.1, 100.0)):
    cam.data.type, cam.data.clip_start, cam.data.clip_end = typ, cs, ce
    g = passes.render_gbuffer(sc, ("albedo", "normal", "depth", "direct", "eevee"))
    np.savez(f"{out_dir}/{name}.npz", **g)
    meta[name] = {"clip_end": ce}
# the SSGI render path with a depth-but-no-normal model, orthographic camera (background depth = clip end)
cam.data.type, cam.data.clip_start, cam.data.clip_end = "ORTHO", 0.001, 1e5
setup_scene(sc, model)
s = R.RenderSession(sc, [1], model=model, write=False, keep_groups=True)
s.run()
info = s.results[0]
np.savez(f"{out_dir}/session.npz", prediction=info["prediction"], **info["groups"])
meta["session_repaired"] = info["repaired_pixels"]
# and with the perspective 0.001 .. 1e5 camera, whose sky depth EEVEE writes as +Inf
cam.data.type = "PERSP"
s = R.RenderSession(sc, [1], model=model, write=False, keep_groups=True)
s.run()
meta["persp_session_repaired"] = s.results[0]["repaired_pixels"]
meta["persp_session_inf_depth"] = int(np.isinf(s.results[0]["groups"]["depth"]).sum())
json.dump(meta, open(f"{out_dir}/meta.json", "w"))
'''


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    d = tmp_path_factory.mktemp("hard-depth")
    torch.manual_seed(0)
    net = network.build(network.arch_for("unet_s", NO_NORMAL))
    model = d / "no_normal.pt"
    checkpoint.save(model, checkpoint.make(net, "network", command="hard-cases depth"))
    run_py(RENDER, str(d), str(model), timeout=850)
    out = {k: dict(np.load(d / f"{k}.npz")) for k in ("persp_1e5", "ortho_1e5", "persp_100", "session")}
    out["meta"] = json.loads((d / "meta.json").read_text())
    out["model"] = model
    return out


def _sky(g) -> np.ndarray:
    """The no-geometry pixels: zero normal (what EEVEE writes where nothing is hit)."""
    return np.linalg.norm(g["normal"], axis=-1) < 0.5


def _depth_input(g, spec=ch.DEFAULT_INPUTS) -> np.ndarray:
    x, _ = normalize.to_inputs(g, spec)
    assert np.isfinite(x).all()
    return x[..., normalize.layout(spec)["depth"]][..., 0]


@pytest.mark.parametrize("name", ["persp_1e5", "ortho_1e5", "persp_100"])
def test_depth_extremes_normalise_to_finite_well_defined_values(renders, name):
    """Case 3: with clip 0.001 .. 1e5 (perspective and orthographic) and 0.1 .. 100, the sky (no geometry) is
    present, whatever EEVEE writes there (+Inf in perspective at clip end 1e5: half-float overflow; the clip
    end 1e5 in orthographic; ~100 at clip end 100), and normalises to exactly 1; geometry normalises into
    (0, 1), the wall 4 m away measures 4 m; the render path's world mask finds exactly the sky."""
    from ssgi.ssgi_addon.pipeline import render as R

    g = renders[name]
    assert g["depth"].shape == (H, W, 1)
    sky = _sky(g)
    assert sky[:5].all() and not sky[-5:].any()  # sky above, wall below
    dn = _depth_input(g)
    assert (dn[sky] == 1.0).all()
    assert ((dn[~sky] > 0) & (dn[~sky] < 1)).all()
    wall = g["depth"][-3:, :5, 0]  # lower left: the wall, clear of the cube
    np.testing.assert_allclose(wall, 4.0, rtol=2e-3)
    ce = renders["meta"][name]["clip_end"]
    np.testing.assert_array_equal(R.world_mask(g, ce), sky)
    raw_sky = g["depth"][sky, 0]
    if name == "persp_1e5":
        assert np.isinf(raw_sky).all()  # measured: EEVEE's half-float depth overflows past 65504
    else:
        assert np.isfinite(raw_sky).all() and (raw_sky >= 0.999 * ce).all()


def test_near_clip_and_scale_freedom(renders):
    """Case 3: a card 5 mm from the lens (clip start 0.001) has a finite depth of ~5 mm and a normalised
    depth in (0, 1); where both perspective clip ranges see the same geometry, the normalised depth agrees
    (the normalisation does not depend on the clip range)."""
    a, b = renders["persp_1e5"], renders["persp_100"]
    near = (a["depth"][..., 0] > 0) & (a["depth"][..., 0] < 0.05)
    assert near.sum() >= 4, "the card 5 mm in front of the lens is not in the picture"
    np.testing.assert_allclose(a["depth"][near, 0], 0.005, rtol=0.05)
    assert not ((b["depth"][..., 0] < 0.05).any())  # clipped away at clip start 0.1
    da, db = _depth_input(a), _depth_input(b)
    assert ((da[near] > 0) & (da[near] < 0.01)).all()
    both = ~_sky(a) & ~_sky(b) & ~near
    # the card shifts the median of the first image a little: compare after undoing each image's median
    za, zb = a["depth"][both, 0], b["depth"][both, 0]
    np.testing.assert_allclose(za, zb, rtol=2e-3)
    ma = np.median(a["depth"][~_sky(a), 0])
    np.testing.assert_allclose(da[both], za / (za + ma), rtol=1e-5)


def test_render_path_without_normal_input_keeps_sky_as_background(renders):
    """Case 3: in the SSGI render path, a model whose inputs have depth but no normal still sees the sky as
    background (normalised depth 1) although the orthographic sky depth (1e5) is finite: the normal pass
    that marks no-geometry pixels is rendered and used, as in training (data.py reads normal for every
    spec). The prediction equals the Predictor's on the same passes, normal included."""
    s = renders["session"]
    assert "normal" in s, "the render path did not render the normal pass the depth normalisation needs"
    sky = _sky(s)
    assert sky[:5].all()
    assert (s["depth"][sky, 0] == 1e5).all()
    dn = _depth_input(s, NO_NORMAL)
    assert (dn[sky] == 1.0).all() and ((dn[~sky] > 0) & (dn[~sky] < 1)).all()
    pred = predictor.load_predictor(renders["model"]).predict(s)
    from ssgi.ssgi_addon.pipeline import render as R
    np.testing.assert_allclose(s["prediction"], R.compose(pred, s, 1e5), rtol=1e-5, atol=1e-6)


def test_render_path_reports_repaired_pixels(renders):
    """Cases 1 and 3: the SSGI render path reports the repaired pixel count per frame: 0 for the
    orthographic render (finite sky depth), and exactly the sky's pixels for the perspective 0.001 .. 1e5
    render, whose sky depth EEVEE writes as +Inf."""
    m = renders["meta"]
    assert m["session_repaired"] == 0
    assert m["persp_session_inf_depth"] > 100
    assert m["persp_session_repaired"] == m["persp_session_inf_depth"]
