"""Network inputs from the channel spec: repair, normalise, augment (numpy and torch, bpy-free).

Every rule here is written once and used by training, the baseline and prediction alike.

Repair of non-finite values (``repair``), applied to every group before anything else:
    NaN  -> 0             (no light, black albedo, zero normal, and "no geometry" for depth)
    +Inf -> LIGHT_MAX     (65504, the largest half float) for light/colour/unit groups; depth: background
    -Inf -> 0
A pixel counts as *repaired* once if any of its channels in any group was non-finite; the count is returned.
Negative light is clamped to 0 (light is >= 0); albedo and AO are clamped to [0, 1].

Normalisation (``to_inputs``), per group kind (``channels.Group.kind``):
    scene  (derived)         whole-image statistics (mean log1p(lit), mean albedo, geometry fraction), as is
    color  (albedo)          as is, in [0, 1]
    normal (camera space)    as is, in [-1, 1]
    unit   (ao, surround)    as is, in [0, 1]
    light  (direct, lit)     log1p(x): compressive, 0 -> 0, 1e5 -> 11.5
    depth                    z / (z + m), m = median depth of the geometry pixels of THIS image: scale free
                             (the same for z and 1000 z), in [0, 1); background -> 1.
Geometry pixels for depth are those with a finite depth in (0, DEPTH_BACKGROUND) and, when the image's
normal group is given, a normal of length > 0.5 (nothing-hit pixels have a zero normal). Pixels that are
not geometry are background; an image without geometry is all background (1).

Flip augmentation (``flip_x``) mirrors the image left-right, negates the normal's x component and swaps the
surround group's right and left bins (what was on the camera's right is on its left in the mirror).
"""
from __future__ import annotations

import numpy as np

from . import channels as ch, images

LIGHT_MAX = 65504.0
DEPTH_BACKGROUND = images.DEPTH_BACKGROUND
DESCRIPTION = {
    "version": 1,
    "repair": "NaN->0, +Inf->65504 (depth: background), -Inf->0; light clamped >=0, albedo/ao to [0,1]",
    "light": "log1p(x)",
    "depth": "z/(z+median geometry depth of the image); background (no geometry, z<=0, z>=1e9, non-finite) -> 1",
    "color": "as is", "normal": "as is (camera space)", "unit": "as is",
    "flip": "mirror x, negate normal.x, swap the surround group's right and left bins",
}


def describe() -> dict:
    """The normalisation, as plain data for checkpoints."""
    return dict(DESCRIPTION)


def _kind(name: str) -> str:
    if name in ch.STAT_GROUPS:
        return "stat"  # already normalised statistics
    return ch.GROUPS[name].kind if name in ch.GROUPS else "light"  # derived groups (lit) are light


def layout(spec: tuple[str, ...]) -> dict[str, slice]:
    """Channel slices of each group in the network's input tensor for ``spec``."""
    out, i = {}, 0
    for g in spec:
        n = ch.group_size(g)
        out[g] = slice(i, i + n)
        i += n
    return out


def repair(groups: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], int]:
    """Replace non-finite values by the documented rule. Returns (repaired groups, repaired pixel count)."""
    bad = None
    out = {}
    for name, a in groups.items():
        a = np.asarray(a, dtype=np.float32)
        if a.ndim == 2:
            a = a[..., None]
        kind = _kind(name)
        with np.errstate(invalid="ignore", over="ignore"):
            total = a.sum(dtype=np.float32)
        if not np.isfinite(total):  # fast path: a finite sum means all values are finite
            finite = np.isfinite(a)
            b = ~finite.all(axis=-1)
            bad = b if bad is None else bad | b
            hi = np.float32(np.inf if kind == "depth" else LIGHT_MAX)  # depth: inf becomes background later
            a = np.where(np.isnan(a), np.float32(0.0), a)
            a = np.where(a == np.inf, hi, a)
            a = np.where(a == -np.inf, np.float32(0.0), a).astype(np.float32)
        lo, hi = {"light": (0.0, LIGHT_MAX), "color": (0.0, 1.0), "unit": (0.0, 1.0), "normal": (-1.0, 1.0)}.get(kind, (None, None))
        if lo is not None:
            a = np.clip(a, np.float32(lo), np.float32(hi))
        out[name] = a
    return out, int(bad.sum()) if bad is not None else 0


def depth_median(depth: np.ndarray, normal: np.ndarray | None = None) -> float | None:
    """The median depth of the pixels with geometry (float32 value), None where nothing was hit."""
    z = np.asarray(depth, dtype=np.float32)
    z = z[..., 0] if z.ndim == 3 else z
    zg = z[images.geometry_mask(z, normal)]
    return float(np.float32(np.median(zg))) if zg.size else None


def depth_normalise(depth: np.ndarray, normal: np.ndarray | None = None, median: float | None = None) -> np.ndarray:
    """HxWx1 float32 in [0, 1]: z/(z+median), background 1. Scale free and finite for any input. ``median``: the
    whole image's (``image_stats``) for a crop of it; None: this image's own."""
    z = np.asarray(depth, dtype=np.float32)
    if z.ndim == 3:
        z = z[..., 0]
    geo = images.geometry_mask(z, normal)
    out = np.ones(z.shape, dtype=np.float32)
    zg = z[geo]
    if zg.size:
        # float64, then rounded once to float32: monotone in z (float32 division of z / (z + m) is not: measured
        # 16384 -> 0.9999999 < 10923 -> 0.99999994 with m = 0.001)
        z64 = zg.astype(np.float64)
        m = np.float64(np.float32(np.median(zg) if median is None else median))
        out[geo] = (z64 / (z64 + m)).astype(np.float32)
    return out[..., None]


def derived(name: str, groups: dict[str, np.ndarray]) -> np.ndarray:
    """A derived group from its (repaired) stored groups."""
    if name == "lit":
        return np.minimum(groups["albedo"] * groups["direct"], LIGHT_MAX).astype(np.float32)
    if name in ("scene", "scene_comb"):
        alb = groups["albedo"]
        if name == "scene":
            lit = derived("lit", groups)
        else:  # scene_comb: the GI-off Combined image is light on the albedo already
            lit = np.minimum(groups["eevee_combined"][..., :3], LIGHT_MAX).astype(np.float32)
        # its own geometry rule, not images.geometry_mask: the shipped model was trained on it (images.py)
        geo = np.abs(groups["normal"]).sum(-1) > 0.5 if "normal" in groups else np.ones(alb.shape[:2], bool)
        stats = np.zeros(7, np.float32)
        if geo.any():
            # sorted float64 sums: the same bits for the image and its mirror (flip augmentation commutes)
            stats[0:3] = np.sort(np.log1p(lit[geo]), axis=0).sum(0, dtype=np.float64) / geo.sum()
            stats[3:6] = np.sort(alb[geo], axis=0).sum(0, dtype=np.float64) / geo.sum()
            stats[6] = geo.mean()
        return np.broadcast_to(stats, alb.shape[:2] + (7,)).astype(np.float32)
    if name == "glow":
        em = groups["emission"]
        stats = np.zeros(4, np.float32)
        if em.size:
            # sorted float64 sums, as for "scene": mirror-invariant bits
            stats[0:3] = np.sort(np.log1p(em.reshape(-1, 3)), axis=0).sum(0, dtype=np.float64) / em.shape[0] / em.shape[1]
            stats[3] = (em.max(axis=-1) > 0.01).mean()
        return np.broadcast_to(stats, em.shape[:2] + (4,)).astype(np.float32)
    raise KeyError(name)


def missing_groups(spec: tuple[str, ...], groups) -> list[str]:
    return [g for g in ch.required_groups(spec) if g not in groups]


def _repaired(groups: dict[str, np.ndarray], spec: tuple[str, ...]) -> tuple[dict[str, np.ndarray], int]:
    need = ch.required_groups(spec)
    extra = ("normal",) if "depth" in spec and "normal" in groups and "normal" not in need else ()
    return repair({g: groups[g] for g in need + extra})


def image_stats(groups: dict[str, np.ndarray], spec: tuple[str, ...]) -> dict:
    """The whole-image values ``to_inputs`` derives for ``spec`` (the STAT_GROUPS' vectors and the depth's
    median): given back to ``to_inputs`` they make a crop's input equal the whole image's on that crop."""
    rep, _ = _repaired(groups, spec)
    out = {g: derived(g, rep)[0, 0].copy() for g in spec if g in ch.STAT_GROUPS}
    if "depth" in spec:
        out["depth_median"] = depth_median(rep["depth"], rep.get("normal"))
    return out


def to_inputs(groups: dict[str, np.ndarray], spec: tuple[str, ...], stats: dict | None = None) -> tuple[np.ndarray, int]:
    """The network input for ``spec`` as an HxWxC float32 array (C = channels.input_channels(spec)), finite
    everywhere, and the number of repaired pixels. ``groups`` are raw HxWxC arrays as read from a sample.
    ``stats``: ``image_stats`` of the whole image when ``groups`` are a crop of it (None: this image's own)."""
    x, n_bad, _ = inputs_and_stats(groups, spec, stats)
    return x, n_bad


def inputs_and_stats(groups: dict[str, np.ndarray], spec: tuple[str, ...],
                     stats: dict | None = None) -> tuple[np.ndarray, int, dict]:
    """``to_inputs`` and the whole-image values it used: ``stats`` or, when None, this image's own (then equal to
    ``image_stats``, without a second pass: the predictor's output bound and the working resolution's crops near
    emitters read them)."""
    rep, n_bad = _repaired(groups, spec)
    h, w = next(iter(rep.values())).shape[:2]
    x = np.empty((h, w, ch.input_channels(spec)), np.float32)
    used = {}
    for g, sl in layout(spec).items():
        if g in ch.STAT_GROUPS:  # kind "stat": stored as derived() makes them
            used[g] = stats[g] if stats is not None else derived(g, rep)[0, 0].copy()
            x[..., sl] = used[g]
            continue
        a = derived(g, rep) if g in ch.DERIVED else rep[g]
        kind = _kind(g)
        if kind == "light":
            np.log1p(a, out=x[..., sl])
        elif kind == "depth":
            m = stats.get("depth_median") if stats is not None else depth_median(a, rep.get("normal"))
            used["depth_median"] = m
            x[..., sl] = depth_normalise(a, rep.get("normal"), m)
        else:
            x[..., sl] = a
    return x, n_bad, used


def light_forward(x):
    """The compressive transform of light passes and of the loss space: log1p (numpy or torch)."""
    if isinstance(x, np.ndarray):
        return np.log1p(np.maximum(x, 0))
    return x.clamp_min(0).log1p()


def light_inverse(y):
    """Inverse of ``light_forward``: expm1."""
    if isinstance(y, np.ndarray):
        return np.expm1(y)
    return y.expm1()


def target(groups: dict[str, np.ndarray], group: str = ch.TARGET_GROUP) -> np.ndarray:
    """The training target ``group`` (``channels.TARGETS``) as linear HDR RGB (HxWx3 float32); NOT repaired
    (callers check). ``ref_combined`` is the whole image ``ref``: its network's output is the whole image (head
    residual_combined), the prediction the part it adds to eevee_combined."""
    if group == ch.COMBINED_TARGET:
        group = ch.TARGET_GROUP
    return np.asarray(groups[group], dtype=np.float32)[..., :3]


def _mirror_channels(spec: tuple[str, ...]) -> list[int]:
    """The channel order of the mirrored input: the surround group's right (R*) and left (L*) bins swap."""
    lay = layout(spec)
    order = list(range(ch.input_channels(spec)))
    if "surround" in lay:
        i0, comps = lay["surround"].start, ch.SURROUND_COMPONENTS
        for k, c in enumerate(comps):
            if c[0] in "RL":
                order[i0 + k] = i0 + comps.index({"R": "L", "L": "R"}[c[0]] + c[1:])
    return order


def flip_x(x, spec: tuple[str, ...], axis: int = -1):
    """Mirror an input tensor left-right, negate normal.x and swap the surround group's right and left bins.
    ``x`` is numpy HxWxC (axis=-1 channel last) or torch NxCxHxW (pass axis=1 for channel axis). Width is the
    axis after H."""
    lay = layout(spec)
    order = _mirror_channels(spec) if "surround" in lay else None
    if isinstance(x, np.ndarray):
        assert axis == -1
        y = x[:, ::-1].copy()
        if order is not None:
            y = y[..., order]
        if "normal" in lay:
            y[..., lay["normal"].start] *= -1
        return y
    import torch
    y = torch.flip(x, dims=[-1])
    if order is not None:
        y = y[:, order]
    if "normal" in lay:
        i = lay["normal"].start
        y = y.clone()
        y[:, i] = -y[:, i]
    return y
