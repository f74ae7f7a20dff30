"""The diffuse-part target (bpy-free), the composition, the emission inputs, the room mode in a
dataset's identity."""
from __future__ import annotations

import numpy as np
import pytest

from ssgi.model import channels as ch, normalize
from ssgi.model.dataset import folder, synthetic
from ssgi.model.errors import UserError
from ssgi.model.infer.compose import compose, needs


def test_a_diffuse_part_prediction_is_added_to_eevees_rest_and_a_whole_image_keeps_eevees_sky():
    pred = np.full((2, 3, 3), 0.5, np.float32)
    rest = np.zeros((2, 3, 3), np.float32)
    rest[0, 0] = (4.0, 2.0, 1.0)  # an emitter (or a highlight): EEVEE's own
    rest[1, 2] = -0.7  # an anti-aliased edge where Combined < Diffuse Color x Diffuse Light
    out = compose(pred, {"rest": rest}, "ref_diffuse")
    assert out[0, 0].tolist() == [4.5, 2.5, 1.5] and out[0, 1].tolist() == [0.5] * 3
    assert out[1, 2].tolist() == [0.0] * 3  # never negative
    bg = np.zeros((2, 3), bool)
    bg[0, 0] = True
    eevee = np.full((2, 3, 4), 0.25, np.float32)
    old = compose(pred, {"eevee": eevee}, "ref", bg)
    assert old[0, 0].tolist() == [0.25] * 3 and old[1, 1].tolist() == [0.5] * 3
    assert needs("ref_diffuse") == ("rest",) and needs("ref") == ("eevee",)
    with pytest.raises(UserError, match="rest"):
        compose(pred, {}, "ref_diffuse")
    with pytest.raises(UserError, match="unknown target"):
        compose(pred, {"rest": rest}, "image")


def test_glow_tells_every_pixel_how_much_the_emitters_on_screen_give_off_and_commutes_with_the_flip():
    em = np.zeros((4, 6, 3), np.float32)
    em[1, 4] = (np.e - 1, 0, 0)  # log1p -> 1
    g = normalize.derived("glow", {"emission": em})
    assert g.shape == (4, 6, 4) and np.allclose(g[0, 0], [1 / 24, 0, 0, 1 / 24]) and np.allclose(g[3, 5], g[0, 0])
    assert np.array_equal(normalize.derived("glow", {"emission": em[:, ::-1]}), g)
    x, _ = normalize.to_inputs({"emission": em}, ("emission", "glow"))
    assert x.shape == (4, 6, 7) and np.isclose(x[1, 4, 0], 1.0)  # light kind: log1p; glow as is
    assert ch.input_channels(("emission", "glow")) == 7


def test_a_dataset_with_the_diffuse_part_trains_on_it_and_the_checkpoint_says_so(tmp_path):
    from ssgi.model.infer.predictor import load_predictor
    from ssgi.model.learn import data
    from ssgi.model.learn.config import TrainConfig
    from ssgi.model.learn.train import Trainer

    root = synthetic.make_dataset(tmp_path / "d", scenes=3, per_scene=1, w=24, h=16, emission=True)
    m = folder.open_folder(root)
    assert data.default_target(m) == "ref_diffuse"
    old = synthetic.make_dataset(tmp_path / "o", scenes=2, per_scene=1, w=8, h=8)
    assert data.default_target(folder.open_folder(old)) == "ref"
    spec = "albedo,normal,depth,direct,emission,lit,glow"
    ds = data.DatasetFolder.load(root, spec)
    s = ds.samples[0]
    em = synthetic.with_emission(synthetic.sample(24, 16, 0, 0), 0)  # y is the diffuse part: no emission in it
    assert ds.target == "ref_diffuse" and float(s.y.max()) < float(np.max(em["ref"])) + 1e-6
    out = tmp_path / "m.pt"
    Trainer(TrainConfig(data=str(root), out=str(out), variant="unet_s", inputs=spec, epochs=1, crop=16, batch=2)).run()
    p = load_predictor(out)
    assert p.target == "ref_diffuse" and p.arch["target"] == "ref_diffuse"
    # --init: a whole-image model with fewer inputs starts a diffuse-part training with more
    first = tmp_path / "first.pt"
    Trainer(TrainConfig(data=str(old), out=str(first), variant="unet_s", inputs="albedo,normal,depth,direct",
                        epochs=1, crop=8, batch=2)).run()
    grown = tmp_path / "grown.pt"
    t = Trainer(TrainConfig(data=str(root), out=str(grown), variant="unet", inputs=spec, epochs=1, crop=16, batch=2,
                            init=str(first)))
    t.run()
    g = load_predictor(grown)
    assert g.arch["variant"] == "unet_s" and g.target == "ref_diffuse" and tuple(g.spec) == tuple(spec.split(","))
    with pytest.raises(UserError, match="ref_diffuse"):  # an old dataset has no diffuse part to learn
        data.DatasetFolder.load(old, "albedo,normal,depth,direct", target="ref_diffuse")


def test_a_folder_of_one_room_mode_refuses_a_bake_of_another():
    m = folder.new_manifest({"kind": "rooms", "room_mode": "artist"}, "5.0.1")
    with pytest.raises(UserError, match="room_mode='artist'"):
        folder.check_compatible(m, {"kind": "rooms"}, "DIR")
    folder.check_compatible(m, {"kind": "rooms", "room_mode": "artist"}, "DIR")


def test_init_grows_the_inputs_with_zero_weights_so_training_starts_from_the_given_models_predictions(tmp_path):
    import torch

    from ssgi.model import normalize
    from ssgi.model.learn import ablation, network

    torch.manual_seed(0)
    for variant in ("unet_s", "unet"):
        old = network.build(network.arch_for(variant, "albedo,normal,depth,direct,lit"))
        new = ablation.grow_inputs(old, "albedo,normal,depth,direct,emission,emit_direct,lit,glow", target="ref_diffuse")
        assert new.arch["target"] == "ref_diffuse" and network.target_of(old.arch) == "ref"
        g = synthetic.with_emission(synthetic.sample(32, 16, 1, 1), 1)
        g["emit_direct"] = g["direct"] * 0.5
        xo, _ = normalize.to_inputs(g, tuple(old.arch["inputs"]))
        xn, _ = normalize.to_inputs(g, tuple(new.arch["inputs"]))
        with torch.no_grad():
            a = old(torch.from_numpy(xo).permute(2, 0, 1)[None])
            b = new(torch.from_numpy(xn).permute(2, 0, 1)[None])
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-5)
        with pytest.raises(UserError, match="do not hold"):
            ablation.grow_inputs(old, "albedo,direct")
