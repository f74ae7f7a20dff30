"""A shot's reflection map (model/infer/reflmap.py, model/learn/reflmap.py), bpy-free: the reflected rays,
where it corrects, the field's training on an environment, the weight, the file. The Blender half (views with rest
and gloss, a fit writing it, the node applying it) is in tests/blender/test_fit_shot.py."""
from __future__ import annotations

import numpy as np
import pytest

from ssgi.model.dataset import exrio, folder
from ssgi.model.errors import UserError
from ssgi.model.infer import reflmap as rm
from ssgi.model.learn import reflmap as lrm

from .test_lightmap import perspective, pose


def test_reflected_rays_mirror_the_view_ray_about_the_normal():
    H, W = 12, 16
    P = perspective(w=W, h=H, shift_x=0.0)
    depth = np.full((H, W), 5.0, np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0  # a wall facing the camera
    pw, r = rm.reflected(depth, normal, np.eye(4), P)
    v = pw / np.linalg.norm(pw, axis=-1, keepdims=True)  # the camera sits at the origin
    assert np.allclose(np.linalg.norm(r, axis=-1), 1.0, atol=1e-5)
    assert np.allclose(r, v * np.array([1, 1, -1]), atol=1e-5)  # z flips, x and y go on
    assert r[..., 2].min() > 0.9  # back towards the camera
    # a moved, turned camera: the same wall in its own frame reflects the same way, turned with it
    M = pose()
    pw2, r2 = rm.reflected(depth, normal, M, P)
    assert np.allclose(r2, r @ M[:3, :3].T, atol=1e-4)
    # orthographic: every view ray is the camera's -Z, so every reflection of the facing wall is +Z
    Po = np.eye(4)
    Po[0, 0], Po[1, 1] = 0.2, 0.2 * W / H
    _, ro = rm.reflected(depth, normal, np.eye(4), Po)
    assert np.allclose(ro, [0, 0, 1], atol=1e-6)


def _frame(H=12, W=16, gloss=0.9):
    """A wall facing the camera: the left half matte (gloss 0), the right half a mirror; one sky pixel."""
    depth = np.full((H, W, 1), 5.0, np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0
    depth[0, 0] = 1e10
    normal[0, 0] = 0.0
    g = np.zeros((H, W, 3), np.float32)
    g[:, W // 2:] = gloss
    return dict(depth=depth, normal=normal, gloss=g)


def env(d):
    """What the mirror should reflect: light from +X, dark from -X."""
    return (0.4 + 0.3 * d[..., :1]) * np.array([1.0, 0.8, 0.6], np.float32)


def test_the_map_learns_from_glossy_pixels_away_from_edges_and_corrects_every_glossy_pixel():
    g = _frame()
    w = [(np.zeros((4, rm.n_features(1, 1)), np.float32), np.zeros(4, np.float32)),
         (np.zeros((3, 4), np.float32), np.array([0.5, 0.5, 0.5], np.float32))]  # a constant field of 0.5
    m = rm.ReflectionMap(w, np.zeros(3), np.ones(3), 1, 1, lam=1.0)
    mask = rm.glossy_mask(g)
    assert not mask[:, :8].any()  # matte: nothing to correct
    assert not mask[:, 8].any() and not mask[:, 7].any()  # the gloss edge between the halves
    assert mask[3:, 10:].all()
    # the node corrects the gloss edge too (its gloss is the mirror's share of the pixel), never the matte half
    every = rm.glossy_mask(g, edges=True)
    assert every[:, 8].all() and not every[:, :8].any() and (every & ~mask).any()
    assert np.array_equal(every, (g["gloss"] > rm.GLOSS_MIN).any(-1) & (g["depth"][..., 0] < 1e9))
    rest = np.full((12, 16, 3), 0.1, np.float32)
    out = m.apply(rest, g, np.eye(4), perspective(w=16, h=12))
    assert np.allclose(out[~every], 0.1) and np.allclose(out[every], 0.1 + 0.9 * 0.5)
    m.lam = 0.0
    assert m.apply(rest, g, np.eye(4), perspective(w=16, h=12)) is rest


def _points(n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3)).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pos = rng.uniform(-0.1, 0.1, (n, 3)).astype(np.float32)
    gloss = np.full((n, 3), 0.9, np.float32)
    base = np.full((n, 3), 0.05, np.float32)  # EEVEE's reflection: too dark
    return dict(pos=pos, dir=d, gloss=gloss, base=base, ref=base + gloss * env(d))


def test_the_field_learns_an_environment_and_generalises_to_new_directions():
    field, stats = lrm.train_field(_points(8000, 0), seconds=120.0, seed=0, steps=300)
    test = _points(2000, 1)
    img = np.clip(test["base"] + test["gloss"] * field.field(test["pos"], test["dir"]), 0, 1)
    err = np.abs(img - test["ref"]).mean()
    before = np.abs(test["base"] - test["ref"]).mean()
    assert before > 0.25 and err < 0.1 * before, (before, err)
    assert stats["loss"] < 0.1 * stats["loss_without"]
    with pytest.raises(UserError, match="glossy pixels in the training views"):
        lrm.train_field(_points(10, 0), seconds=1.0)


def test_the_weight_is_chosen_on_the_views_and_the_file_round_trips(tmp_path):
    """Views of a mirror wall whose EEVEE rest is too dark: the fitted map is used (weight 1); a wrong map is not."""
    H, W = 24, 32
    P = perspective(w=W, h=H, shift_x=0.0)
    cams = {}
    for i, M in enumerate((np.eye(4), pose(0.1, 0.2, (0.3, 0.0, 0.5)), pose(-0.1, -0.2, (-0.3, 0.1, 0.2)))):
        g = _frame(H, W)
        _, r = rm.reflected(g["depth"], g["normal"], M, P)
        rest = np.full((H, W, 3), 0.05, np.float32)
        rd = np.full((H, W, 3), 0.2, np.float32) * (g["gloss"] == 0)
        ref = rd + rest + g["gloss"] * env(r)
        k = f"{i:06d}"
        exrio.write_sample(folder.sample_path(tmp_path, k), dict(g, rest=rest, ref=ref, ref_diffuse=rd), half=False)
        cams[k] = {"M": M.tolist(), "P": P.tolist()}
    field, rep = lrm.fit_reflmap(tmp_path, cams, ["000000", "000001"], ["000002"], seconds=60.0, steps=400)
    assert rep["lam"] == 1.0 and rep["val_psnr"]["1.0"] > rep["val_psnr"]["0.0"] + 6, rep
    assert rep["points"] == 2 * int(rm.glossy_mask(_frame(H, W)).sum())
    bad = rm.ReflectionMap([(w, b + (3.0 if i == len(field.weights) - 1 else 0.0)) for i, (w, b) in
                            enumerate(field.weights)], field.lo, field.hi, field.nfreq_pos, field.nfreq_dir)
    lam, scores = lrm.choose_weight(bad, tmp_path, cams, ["000002"])
    assert lam == 0.0 and scores[0.0] > scores[0.5]
    # the file, beside the model
    model = tmp_path / "shot.pt"
    p = field.save(rm.path_for(model))
    assert p.name == "shot.reflmap.npz" and rm.path_for(tmp_path / "shot.onnx") == p
    back = rm.load_beside(model)
    d = _points(50, 2)
    assert back.lam == 1.0 and np.array_equal(back.field(d["pos"], d["dir"]), field.field(d["pos"], d["dir"]))
    field.lam = 0.0
    field.save(p)
    assert rm.load_beside(model) is None  # written, but the fit chose not to use it
    p.write_bytes(b"not a zip")
    with pytest.raises(UserError, match=r"shot\.reflmap\.npz: cannot read the reflection map"):
        rm.load_beside(model)
    np.savez(p, lo=np.zeros(3))
    with pytest.raises(UserError, match="not an SSGI reflection map"):
        rm.load_beside(model)
    # a view without EEVEE's rest and gloss (a fit that did not bake them) is a clear error
    exrio.write_sample(folder.sample_path(tmp_path, "000009"), dict(_frame(H, W)), half=False)
    with pytest.raises(UserError, match=r"000009\.exr: missing channel"):
        lrm.points(tmp_path, cams | {"000009": cams["000000"]}, ["000009"])


def test_a_combined_models_map_learns_and_is_weighed_only_where_its_image_takes_it(tmp_path):
    """A ref_combined model's image takes the map only where the albedo is black (reflmap.combined_weight). Views of a
    wall whose glossy half is metal above (black albedo, EEVEE's reflection too dark) and glossy paint below (albedo
    0.5, EEVEE's reflection right): the map learns from the metal alone and is weighed on what the model's image does
    with it, not refused for what it would do to the paint."""
    H, W = 24, 32
    P = perspective(w=W, h=H, shift_x=0.0)
    cams = {}
    metal = np.zeros((H, W), bool)
    metal[: H // 2, W // 2:] = True
    for i, M in enumerate((np.eye(4), pose(0.1, 0.2, (0.3, 0.0, 0.5)), pose(-0.1, -0.2, (-0.3, 0.1, 0.2)))):
        g = _frame(H, W)
        _, r = rm.reflected(g["depth"], g["normal"], M, P)
        albedo = np.where(metal[..., None], 0.0, 0.5).astype(np.float32) * np.ones(3, np.float32)
        rest = np.full((H, W, 3), 0.05, np.float32)
        rd = (0.2 * albedo).astype(np.float32)
        ref = rd + rest + np.where(metal[..., None], g["gloss"] * env(r), 0.0)
        k = f"{i:06d}"
        exrio.write_sample(folder.sample_path(tmp_path, k), dict(g, albedo=albedo, rest=rest, ref=ref, ref_diffuse=rd),
                           half=False)
        cams[k] = {"M": M.tolist(), "P": P.tolist()}
    assert np.allclose(rm.combined_weight(np.float32([[0, 0, 0], [0.025, 0, 0.01], [0.5, 0.5, 0.5]])),
                       [[1.0], [0.5], [0.0]])
    pts = lrm.points(tmp_path, cams, ["000000"], combined=True)
    assert len(pts["pos"]) == int((rm.glossy_mask(_frame(H, W)) & metal).sum()) > 0
    assert len(lrm.points(tmp_path, cams, ["000000"])["pos"]) == int(rm.glossy_mask(_frame(H, W)).sum())
    field, rep = lrm.fit_reflmap(tmp_path, cams, ["000000", "000001"], ["000002"], seconds=60.0, steps=400,
                                 combined=True)
    assert rep["combined"] and rep["lam"] == 1.0 and rep["val_psnr"]["1.0"] > rep["val_psnr"]["0.0"] + 3, rep
    # weighed as a diffuse-part model's rest takes it (everywhere glossy), the same map also "corrects" the paint
    _, local = lrm.choose_weight(field, tmp_path, cams, ["000002"])
    assert local[1.0] < rep["val_psnr"]["1.0"] - 1, (local, rep["val_psnr"])


def test_one_rule_says_which_models_take_the_map_on_eevees_gi_off_image():
    """The fit and the render path ask the same question (reflmap.corrects_combined): only a ref_combined model's
    base is EEVEE's GI-off image (corrected where the albedo is black); the others correct EEVEE's rest."""
    from ssgi.model import channels as ch
    from ssgi.model.infer.reflmap import corrects_combined
    assert corrects_combined(ch.COMBINED_TARGET)
    assert not corrects_combined(ch.DIFFUSE_TARGET)
    assert not corrects_combined(ch.TARGET_GROUP)
