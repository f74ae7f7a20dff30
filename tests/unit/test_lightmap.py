"""A shot's lightmap (model/infer/lightmap.py, model/learn/lightmap.py), bpy-free: the camera geometry,
the field's training, the blend and its weight, the file. The Blender half (camera matrices from bpy, a shot fit
writing and the node applying it) is in tests/blender/test_fit_shot.py."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ssgi.model.dataset import exrio, folder
from ssgi.model.errors import UserError
from ssgi.model.infer import lightmap as lm
from ssgi.model.learn import lightmap as llm


def perspective(lens=50.0, sensor=36.0, w=64, h=36, shift_x=0.1, near=0.1, far=100.0):
    """Blender's projection of a sensor-fit-horizontal camera (what calc_matrix_camera returns)."""
    P = np.zeros((4, 4))
    P[0, 0] = 2 * lens / sensor
    P[1, 1] = 2 * lens / sensor * w / h
    P[0, 2] = 2 * shift_x
    P[2, 2] = -(far + near) / (far - near)
    P[2, 3] = -2 * far * near / (far - near)
    P[3, 2] = -1
    return P


def pose(rx=0.3, ry=-0.5, t=(1.0, 2.0, 3.0)):
    cx, sx, cy, sy = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry)
    R = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    M = np.eye(4)
    M[:3, :3], M[:3, 3] = R, t
    return M


def test_world_points_and_project_are_inverse():
    rng = np.random.default_rng(0)
    M, P = pose(), perspective()
    depth = rng.uniform(1.0, 9.0, (36, 64)).astype(np.float32)
    normal = np.zeros((36, 64, 3), np.float32)
    normal[..., 2] = 1.0
    pw, nw = lm.world_points(depth, normal, M, P)
    u, v, d = lm.project(pw, M, P, 64, 36)
    cols, rows = np.meshgrid(np.arange(64), np.arange(36))
    assert np.abs(u - cols).max() < 1e-3 and np.abs(v - rows).max() < 1e-3
    assert np.abs(d - depth).max() < 1e-4
    # a camera-space normal towards the camera is the camera's +Z axis in the world
    assert np.allclose(nw, M[:3, 2], atol=1e-5)
    # orthographic: P[3,3] = 1
    Po = np.eye(4)
    Po[0, 0], Po[1, 1], Po[0, 3] = 0.2, 0.2 * 64 / 36, 0.05
    pw, _ = lm.world_points(depth, normal, M, Po)
    u, v, d = lm.project(pw, M, Po, 64, 36)
    assert np.abs(u - cols).max() < 1e-3 and np.abs(d - depth).max() < 1e-4


def test_a_wall_seen_from_two_cameras_is_one_plane():
    """A camera at the origin looking down -Z at a wall 5 units away: every pixel lies on z = -5, and the same
    wall seen by a turned, moved camera gives points on the same plane."""
    P = perspective(shift_x=0.0)
    depth = np.full((36, 64), 5.0, np.float32)
    pw, _ = lm.world_points(depth, np.zeros((36, 64, 3), np.float32), np.eye(4), P)
    assert np.abs(pw[..., 2] + 5.0).max() < 1e-5
    assert pw[..., 0].min() < -1.0 < 1.0 < pw[..., 0].max()  # the view's width: 5 * 36 / 50 = 3.6 units
    assert abs((pw[0, -1, 0] - pw[0, 0, 0]) - 3.6 * 63 / 64) < 1e-3
    # a second camera 1 unit to the right, turned 10 degrees: its depth for the same plane
    M = pose(rx=0.0, ry=math.radians(10), t=(1.0, 0.0, 0.0))
    cols, rows = np.meshgrid(np.arange(64), np.arange(36))
    u, v, d = lm.project(pw, M, P, 64, 36)
    pw2, _ = lm.world_points(np.where(np.isfinite(d), d, 1.0), np.zeros((36, 64, 3), np.float32), M, P)
    # unprojecting at the (non-integer) projected pixel is what project inverts: check through a ray instead
    ray_dir = (pw - M[:3, 3]) / np.linalg.norm(pw - M[:3, 3], axis=-1, keepdims=True)
    fwd = -M[:3, 2]
    assert np.allclose(d, np.linalg.norm(pw - M[:3, 3], axis=-1) * (ray_dir @ fwd), rtol=1e-4)


def _plane_points(n=20000, seed=0):
    """Points on the floor, the back wall and the left wall of a 4 x 3 x 4 room, and a smooth light."""
    rng = np.random.default_rng(seed)
    k = rng.integers(0, 3, n)
    u, v = rng.uniform(0, 1, n), rng.uniform(0, 1, n)
    pos = np.where(k[:, None] == 0, np.stack([u * 4, v * 4, 0 * u], 1),
                   np.where(k[:, None] == 1, np.stack([u * 4, 4 + 0 * u, v * 3], 1), np.stack([0 * u, u * 4, v * 3], 1)))
    nrm = np.where(k[:, None] == 0, [0, 0, 1], np.where(k[:, None] == 1, [0, -1, 0], [1, 0, 0])).astype(np.float32)
    light = np.stack([0.6 + 0.3 * np.sin(pos[:, 0]) * np.cos(pos[:, 1] * 0.7), 0.5 + 0.2 * pos[:, 2] / 3,
                      0.4 + 0.1 * (k == 2)], 1)
    return pos.astype(np.float32), nrm, light.astype(np.float32)


def test_the_field_learns_a_smooth_light_and_generalises_to_new_points():
    pos, nrm, y = _plane_points(20000, 0)
    field, stats = llm.train_field(pos, nrm, y, seconds=600.0, seed=0, steps=300)  # steps: the same under any load
    tp, tn, ty = _plane_points(4000, 1)  # other points of the same surfaces
    err = np.sqrt(np.mean((field.field(tp, tn) - ty) ** 2))
    assert stats["steps"] == 300 and stats["points"] == 20000
    assert err < 0.03, err  # the light spans 0.2-0.9; a field that learned the mean would be ~0.1 off
    const = np.sqrt(np.mean((y.mean(0) - ty) ** 2))
    assert err < 0.3 * const
    with pytest.raises(UserError, match="usable pixels"):
        llm.train_field(pos[:10], nrm[:10], y[:10], seconds=1.0)


def _field(lam=0.5, value=2.0):
    """A field that answers ``value`` everywhere: one linear layer with zero weights."""
    din = 6 + 6 * lm.NFREQ
    return lm.Lightmap([(np.zeros((3, din)), np.full(3, value))], [0, 0, 0], [1, 1, 1], lm.NFREQ, lam)


def _frame(h=12, w=16):
    depth = np.full((h, w, 1), 4.0, np.float32)
    depth[:, w // 2:] = 6.0  # a depth edge down the middle
    depth[0, 0] = 1e10  # nothing hit
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = 1.0
    normal[0, 0] = 0.0
    albedo = np.full((h, w, 3), 0.5, np.float32)
    albedo[-3:, :4] = (0.5, 0.0, 0.5)  # a black channel: no diffuse light to know there
    return {"depth": depth, "normal": normal, "albedo": albedo}


def test_apply_blends_only_where_it_is_safe():
    g = _frame()
    part = np.full((12, 16, 3), 0.3, np.float32)
    out = _field(0.5, 2.0).apply(part, g, np.eye(4), perspective(w=16, h=12))
    w = lm.blend_weight(g, 0.5)
    assert set(np.unique(w)) == {0.0, 0.5}
    e = lm.edges(g["depth"], g["normal"], g["albedo"])
    assert e[:, 7:9].all() and not e[5, 2]  # the depth edge, not the flat wall
    assert np.array_equal(out[w == 0], part[w == 0])  # the sky pixel and the black channel keep the network
    assert w[0, 0] == 0 and (w[-3:, :3] == 0).all()
    # the lightmap is blended on the edges too (network_on_edges=True keeps the network there)
    assert (w[1:-3, 7:9] == 0.5).all()
    assert np.allclose(out[5, 8], 0.5 * 0.5 * 2.0 + 0.5 * 0.3)
    old = lm.blend_weight(g, 0.5, network_on_edges=True)
    assert (old[:, 7:9] == 0).all() and (old <= w).all() and old[5, 2] == 0.5
    assert np.allclose(out[5, 2], 0.5 * 0.5 * 2.0 + 0.5 * 0.3)  # lam x albedo x light + (1 - lam) x part
    assert _field(0.0).apply(part, g, np.eye(4), perspective(w=16, h=12)) is part
    # at a working-resolution factor the light is evaluated at representative pixels and upsampled: a constant
    # field stays that constant
    big = _field(1.0, 2.0).light(g, np.eye(4), perspective(w=16, h=12), factor=4)
    assert big.shape == (12, 16, 3) and np.allclose(big[g["normal"][..., 2] > 0], 2.0, atol=1e-4)


def test_file_round_trip_and_bad_files(tmp_path):
    pos, nrm, y = _plane_points(3000, 0)
    field, _ = llm.train_field(pos, nrm, y, seconds=60.0, seed=0, steps=20)
    field.lam = 0.75
    model = tmp_path / "shot.pt"
    p = field.save(lm.path_for(model))
    assert p.name == "shot.lightmap.npz" and lm.path_for(tmp_path / "shot.onnx") == p
    back = lm.load_beside(model)
    assert back.lam == 0.75 and np.array_equal(back.field(pos[:50], nrm[:50]), field.field(pos[:50], nrm[:50]))
    field.lam = 0.0
    field.save(p)
    assert lm.load_beside(model) is None  # written, but the fit chose not to use it
    assert lm.load_beside(tmp_path / "other.pt") is None
    p.write_bytes(b"not a zip")
    with pytest.raises(UserError, match=r"shot\.lightmap\.npz: cannot read the lightmap"):
        lm.load_beside(model)
    np.savez(p, lo=np.zeros(3))
    with pytest.raises(UserError, match="not an SSGI lightmap"):
        lm.load_beside(model)


class _Scaled:
    """A stand-in network of known error: the true diffuse part times ``k``."""
    required = ("albedo",)

    def __init__(self, light, k):
        self.light, self.k = light, k

    def predict(self, groups):
        return groups["albedo"][..., :3] * self.light * self.k


def test_the_blend_weight_is_chosen_on_the_validation_views(tmp_path):
    """The views of a wall lit by a constant light 0.8: a field that knows it exactly is preferred over a network
    20 % too dark (a weight > 0), and a network that is exact is preferred over a field that is wrong (0)."""
    g = _frame()
    light = np.float32(0.8)
    rest = np.full((12, 16, 3), 0.01, np.float32)
    ref = g["albedo"] * light + rest
    for k in ("000000", "000001"):
        exrio.write_sample(folder.sample_path(tmp_path, k), dict(g, ref_diffuse=ref - rest), half=False)
    exrio.write_sample(folder.sample_path(tmp_path, "000002"), dict(g, ref=ref), half=False)  # no rest, no diffuse
    cams = {k: {"M": np.eye(4).tolist(), "P": perspective(w=16, h=12).tolist()} for k in ("000000", "000001")}
    lam, scores = llm.choose_weight(_field(0.0, 0.8), tmp_path, cams, ["000000", "000001"], _Scaled(light, 0.8),
                                    "ref_diffuse")
    assert lam == 1.0 and scores[1.0] > scores[0.5] > scores[0.0]
    lam, scores = llm.choose_weight(_field(0.0, 0.4), tmp_path, cams, ["000000", "000001"], _Scaled(light, 1.0),
                                    "ref_diffuse")
    assert lam == 0.0 and scores[0.0] > scores[0.25]
    with pytest.raises(UserError, match=r"000002\.exr: missing channel\(s\) ref_diffuse"):
        llm.choose_weight(_field(0.0, 0.8), tmp_path, cams | {"000002": cams["000000"]}, ["000002"],
                          _Scaled(light, 1.0), "ref_diffuse")
    # the target of a one-render fit: what its prediction adds to EEVEE's GI-off image, signed, per view
    t = llm.view_target(dict(ref=ref, eevee_combined=rest + 0.1), "ref_combined")
    assert np.allclose(t, g["albedo"] * light - 0.1)
    # the points of the views: every usable pixel, light = target / albedo
    pos, nrm, y = llm.points(tmp_path, cams, ["000000"], "ref_diffuse")
    from ssgi.model.images import geometry_mask
    usable = geometry_mask(g["depth"], g["normal"]) & (g["albedo"] > lm.ALBEDO_MIN).all(-1)
    assert len(pos) == int(usable.sum()) == 12 * 16 - 1 - 12 and np.allclose(y, 0.8, atol=1e-5)
    with pytest.raises(UserError, match="no camera matrices"):
        llm.points(tmp_path, {}, ["000000"], "ref_diffuse")


def test_a_field_of_the_light_minus_the_frames_direct_light_follows_a_moving_shadow(tmp_path):
    """A floor lit by a lamp whose shadow (a moving object's) is somewhere else in every view, plus a smooth
    indirect light. A field of the whole light learns the shadows where the views had them; a field of the light
    minus the frame's own ``direct`` pass learns only the indirect light and, with the direct pass added back,
    renders a frame with the shadow at a new place. The fit tries both (the model reads ``direct``), keeps the
    known-light one on the validation view, and the file keeps which groups it adds back."""
    H, W = 32, 48
    cols = np.arange(W)[None, :].repeat(H, 0)
    rows = np.arange(H)[:, None].repeat(W, 1)
    indirect = (0.3 + 0.2 * cols / W)[..., None].repeat(3, -1).astype(np.float32)

    def view(shadow_x):
        direct = np.ones((H, W, 3), np.float32)
        direct[(cols - shadow_x) ** 2 + (rows - H / 2) ** 2 < 36] = 0.0
        g = {"depth": np.full((H, W, 1), 3.0, np.float32), "albedo": np.full((H, W, 3), 0.6, np.float32),
             "normal": np.broadcast_to(np.float32([0, 0, 1]), (H, W, 3)).copy(), "direct": direct}
        return dict(g, ref_diffuse=g["albedo"] * (direct + indirect))
    P = perspective(w=W, h=H, shift_x=0.0)
    cams = {}
    for k, x in (("000000", 8), ("000001", 40), ("000002", 24)):
        exrio.write_sample(folder.sample_path(tmp_path, k), view(x), half=False)
        cams[k] = {"M": np.eye(4).tolist(), "P": P.tolist()}

    class Net:  # the network: 10 % too dark everywhere
        required = ("albedo", "direct")

        def predict(self, g):
            return 0.9 * g["albedo"] * (g["direct"] + indirect)
    field, rep = llm.fit_lightmap(tmp_path, cams, ["000000", "000001"], ["000002"], Net(), "ref_diffuse", 600.0,
                                  steps=400)
    assert field.known == ("direct",) and rep["known"] == ["direct"] and field.lam > 0
    assert set(rep["tried"]) == {"none", "direct"}
    assert max(rep["tried"]["direct"]["val_psnr"].values()) > max(rep["tried"]["none"]["val_psnr"].values()) + 3
    test = view(30)  # the shadow where no view had it
    light = field.light(test, np.eye(4), P)
    assert np.abs(light - (test["direct"] + indirect)).mean() < 0.03
    back = field.save(tmp_path / "m.lightmap.npz")
    assert lm.Lightmap.load(back).known == ("direct",)
    with pytest.raises(UserError, match="no direct pass"):
        field.light({k: v for k, v in test.items() if k != "direct"}, np.eye(4), P)
    assert lm.known_for(("albedo", "direct", "direct_soft", "emit_direct")) == ("direct_soft", "emit_direct")
    assert lm.known_for(("albedo", "normal")) == ()
