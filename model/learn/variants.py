"""The named network variants as plain data (no torch here, so ``cli.py --help`` stays fast).

``network.arch_for(name, inputs, **overrides)`` turns one into a complete architecture dict and
``network.build`` into a module; see network.py for what the settings mean.
"""
from __future__ import annotations

from ..errors import UserError

VARIANTS: dict[str, dict] = {
    # the seed's network (Peng 2019), regressing log1p RGB: the reference point the others are measured against
    "fssgi": dict(backbone="fssgi", width=64, pre=4, post=3, head="log"),
    # the shipped models' encoder-decoder (models/ssgi_default.json)
    "unet_s": dict(backbone="unet", widths=[12, 24, 32], convs=[1, 2, 2], head="residual"),
    # a four-level encoder-decoder: the sizes of cli.py fit's ladder (model/learn/fit.py LADDER) override its
    # widths and convs
    "unet": dict(backbone="unet", widths=[16, 32, 48, 64], convs=[1, 2, 2, 2], head="residual"),
    # a per-pixel MLP over the inputs and box means of EEVEE's GI-off image: compiles into compositor nodes
    # (model/compile, docs/compiled.md)
    "boxmlp": dict(backbone="boxmlp", widths=[24, 24], boxes=[1, 3, 5, 7], ref_width=240, head="residual_combined"),
    # the closed-form baseline (baseline.py); not trained by gradient descent
    "linear": dict(backbone="linear", space="linear"),
}
DEFAULT = "unet_s"
TRAINABLE = tuple(k for k, v in VARIANTS.items() if v["backbone"] != "linear")


def check_known(arch: dict, path) -> None:
    """UserError, in one line, when a model file's architecture names a variant this SSGI does not have (one
    that earlier versions trained, such as lean or unet_l)."""
    v = arch.get("variant") if isinstance(arch, dict) else None
    if v is not None and v not in VARIANTS:
        raise UserError(f"{path}: network variant {v!r} is no longer supported; retrain with `cli.py train` "
                        f"(variant {DEFAULT}) or use a shipped model (default, one_render)")
