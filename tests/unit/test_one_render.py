"""One-render models (bpy-free): the whole-image statistics of a combined model (``scene_comb``), and the refusal of
a bake manifest or a model of a one-render kind SSGI no longer has ('gi', which read ``eevee_diffuse``; 'local',
which read ``eevee_local``)."""
from __future__ import annotations

import json
import types

import numpy as np
import pytest

from ssgi.model import channels as ch, normalize
from ssgi.model.dataset import folder as dataset, synthetic
from ssgi.model.errors import UserError


def _groups(h=8, w=12, seed=0):
    r = np.random.default_rng(seed)
    n = r.normal(size=(h, w, 3)).astype(np.float32)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    n[0, :3] = 0  # sky pixels: no normal
    return {"albedo": r.uniform(0.05, 0.9, (h, w, 3)).astype(np.float32), "normal": n,
            "depth": r.uniform(1, 5, (h, w, 1)).astype(np.float32),
            "emission": np.zeros((h, w, 3), np.float32),
            "direct": r.uniform(0, 3, (h, w, 3)).astype(np.float32),
            "surround": np.broadcast_to(r.uniform(0, 1, 12).astype(np.float32), (h, w, 12)).copy()}


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


def test_the_one_render_groups_are_the_combined_kinds_and_the_other_kinds_groups_are_no_input():
    assert ch.ONE_RENDER_GROUPS == ("eevee_combined",)
    assert ch.one_render(("albedo", "eevee_combined", "scene_comb")) and not ch.one_render(("albedo", "direct"))
    # eevee_local is still what a one-render bake stores beside the Combined image, but no model reads it
    assert "eevee_local" in ch.SAMPLE_GROUPS and "eevee_local" in ch.OPTIONAL_GROUPS
    assert "eevee_local" not in ch.INPUT_GROUPS and "eevee_diffuse" not in ch.GROUPS
    assert "scene_gi" not in ch.DERIVED
    with pytest.raises(UserError, match="unknown input group 'eevee_diffuse'"):
        ch.parse_spec("albedo,eevee_diffuse")


@pytest.mark.parametrize("spec,kind", [(("albedo", "eevee_diffuse", "scene_gi"), "gi"), (("albedo", "scene_gi"), "gi"),
                                       (("albedo", "normal", "eevee_local", "glow"), "local")])
def test_a_model_of_a_gone_kind_is_refused_in_one_line_naming_what_to_use(spec, kind):
    assert ch.gone_kind_of_model(spec) == kind
    with pytest.raises(UserError) as e:
        ch.refuse_gone_model(spec, "m.pt")
    msg = str(e.value)
    assert msg.startswith(f"m.pt: was made with the {kind!r} one-render kind, which SSGI no longer has; ")
    assert "`cli.py fit --one-render`" in msg and "\n" not in msg
    assert ch.gone_kind_of_model(("albedo", "eevee_combined", "scene_comb")) is None
    ch.refuse_gone_model(("albedo", "normal", "depth", "direct"), "m.pt")


def test_a_checkpoint_of_a_gone_kind_is_refused_when_it_is_loaded(tmp_path):
    import torch

    from ssgi.model.learn import checkpoint
    path = tmp_path / "local.pt"
    torch.save({"ssgi_checkpoint": checkpoint.CHECKPOINT_VERSION, "arch": {"variant": "unet_s", "head": "residual_local"},
                "state_dict": {}, "inputs": ["albedo", "normal", "depth", "eevee_local", "glow"]}, path)
    with pytest.raises(UserError, match=r"local.pt: was made with the 'local' one-render kind, which SSGI no longer "
                                        r"has; fit a new one with `cli.py fit --one-render`"):
        checkpoint.load(path)


def test_an_onnx_export_of_a_gone_kind_is_refused_when_it_is_read():
    from ssgi.model.infer import onnx as ort_backend
    meta = {"ssgi_onnx": json.dumps(ort_backend.ONNX_VERSION), "inputs": json.dumps(["albedo", "eevee_diffuse"]),
            "arch": json.dumps({}), "multiple": "8", "receptive_field": "45"}
    sess = types.SimpleNamespace(get_modelmeta=lambda: types.SimpleNamespace(custom_metadata_map=meta))
    with pytest.raises(UserError, match=r"gi.onnx: was made with the 'gi' one-render kind"):
        ort_backend.read_meta(sess, "gi.onnx")


@pytest.mark.parametrize("one,kind", [({"kind": "local", "gi_samples": 16}, "local"),
                                      ({"kind": "gi", "gi_samples": 16, "raytracing": True}, "gi"),
                                      ({"gi_samples": 16, "raytracing": True}, "gi"),  # (recorded no kind)
                                      ({"gi_samples": 16, "raytracing": False}, "local"),
                                      ({"kind": "combined", "gi_samples": 16, "raytracing": False}, None)])
def test_a_bake_manifest_of_a_gone_kind_is_refused_in_one_line_naming_the_bake_to_make(tmp_path, one, kind):
    d = synthetic.make_dataset(tmp_path / "d", scenes=1, per_scene=1, w=8, h=8)
    m = json.loads((d / "manifest.json").read_text())
    m["settings"]["eevee"] = {"one_render": one}
    (d / "manifest.json").write_text(json.dumps(m))
    assert ch.gone_kind_of_bake(m["settings"]) == kind
    if kind is None:
        assert dataset.open_folder(d)["settings"]["eevee"]["one_render"] == one
        return
    with pytest.raises(UserError) as e:
        dataset.open_folder(d)
    assert str(e.value) == (f"{d}: was baked with the {kind!r} one-render kind, which SSGI no longer has; "
                            "re-bake with `cli.py bake --gi-samples N --one-render`")
