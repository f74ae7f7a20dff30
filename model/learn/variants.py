"""The named network variants as plain data (no torch here, so ``cli.py --help`` stays fast).

``network.arch_for(name, inputs, **overrides)`` turns one into a complete architecture dict and
``network.build`` into a module; see network.py for what the settings mean.
"""
from __future__ import annotations

VARIANTS: dict[str, dict] = {
    # the seed's network (Peng 2019), regressing log1p RGB
    "fssgi": dict(backbone="fssgi", width=64, pre=4, post=3, head="log"),
    # the seed's network with the residual-shading head
    "fssgi_res": dict(backbone="fssgi", width=64, pre=4, post=3, head="residual"),
    # a narrow, shallow fssgi
    "lean": dict(backbone="fssgi", width=24, pre=3, post=2, head="residual"),
    # encoder-decoders, small to large
    "unet_s": dict(backbone="unet", widths=[12, 24, 32], convs=[1, 2, 2], head="residual"),
    "unet": dict(backbone="unet", widths=[16, 32, 48, 64], convs=[1, 2, 2, 2], head="residual"),
    "unet_l": dict(backbone="unet", widths=[24, 48, 64, 96], convs=[2, 2, 2, 3], head="residual"),
    # one level deeper: receptive field 125 px (more of the room) for little extra cost
    "unet_d": dict(backbone="unet", widths=[16, 32, 48, 64, 96], convs=[1, 2, 2, 2, 2], head="residual"),
    # the closed-form baseline (baseline.py); not trained by gradient descent
    "linear": dict(backbone="linear", space="linear"),
}
DEFAULT = "unet"
TRAINABLE = tuple(k for k, v in VARIANTS.items() if v["backbone"] != "linear")
