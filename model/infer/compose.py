"""The SSGI image from a prediction (bpy-free): what the node shows, for every consumer (render path, report).

A model predicts its checkpoint's target (``Predictor.target``, ``channels.TARGETS``):

- ``ref_diffuse``: the diffuse part of the image only (diffuse colour x diffuse light, direct and indirect).
  The SSGI image is ``prediction + rest``, where ``rest`` (channels.GROUPS["rest"]) is everything else EEVEE
  renders itself at the artist's settings: emission, the world seen directly, glossy and metal reflections,
  transmission, volumes. Where the prediction equals EEVEE's own diffuse part the image is EEVEE's own render
  exactly; nothing-hit pixels have no albedo, so the prediction is 0 there and the sky comes from ``rest``.
- ``ref_combined`` (GI-off one-render models without the Diffuse Direct pass): the SSGI image is
  ``prediction + eevee_combined``, EEVEE's GI-off Combined image plus albedo x the light it lacks (signed: the
  prediction may take light away); albedo-0 pixels (metal, glass, sky) keep EEVEE's image.
- ``ref`` (the first models): the whole image; pixels where nothing was hit (``background``) show
  EEVEE's Combined image (group ``eevee``).
"""
from __future__ import annotations

import numpy as np

from .. import channels as ch
from ..errors import UserError


def needs(target: str) -> tuple[str, ...]:
    """The groups ``compose`` reads besides the prediction, for a model of ``target``."""
    base = ch.base_group(target)
    return (base,) if base else ("eevee",)


def compose(pred: np.ndarray, groups: dict, target: str, background: np.ndarray | None = None) -> np.ndarray:
    """HxWx3 float32 linear RGB, finite and >= 0. ``background``: HxW bool, the pixels where nothing was hit
    (used by ``ref`` models only)."""
    miss = [g for g in needs(target) if g not in groups]
    if miss:
        raise UserError(f"composing the SSGI image of a {target} model needs the group(s) {', '.join(miss)}")
    out = np.array(pred[..., :3], dtype=np.float32, copy=True)
    base = ch.base_group(target)
    if base:
        rest = np.nan_to_num(np.asarray(groups[base], np.float32)[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
        out += rest
        # rest is negative on some anti-aliased edges (mean of products against product of means); the image is not
        np.maximum(out, 0.0, out=out)
        return out
    if background is not None:
        out[background] = np.asarray(groups["eevee"], np.float32)[..., :3][background]
    return out
