"""The inference contract, runtime-free (numpy only: no torch, no onnxruntime, no bpy).

Both runtimes (``predictor.Predictor``: torch, ``onnx.OrtPredictor``: onnxruntime) are a ``ContractPredictor``
with one backend method, ``_forward(x: 1xCxHxW float32, normalised) -> 1x3xHxW float32 linear RGB`` (the
network and ``network.to_linear``, which the ONNX graph holds too). Everything around it is here, once:

1. check the groups (``required``: the stored groups the input spec needs; all the same size);
2. repair and normalise them into the network input (``normalize.to_inputs``: NaN/Inf repair, log1p light,
   scale-free depth, the whole-image ``scene``/``glow`` statistics);
3. pad to the network's size multiple (edge replicate, what the networks do themselves) and run the backend
   in tiles (``run_tiled``: overlapping tiles whose kept cores equal the untiled result);
4. bound the output (``OUTPUT_BOUND`` times the brightest input light) and zero it where the albedo is black.

Models carry their metadata as plain data (``meta``: the checkpoint without its weights; in an .onnx file the
same keys as ``metadata_props``); ``check_versions`` is the one check of its format versions.
"""
from __future__ import annotations

import math

import numpy as np

from .. import channels as ch
from .. import normalize
from ..learn import variants
from ..errors import UserError

OUTPUT_BOUND = 64.0  # a prediction never exceeds OUTPUT_BOUND * max(1, brightest input light value)
DEFAULT_TILE = 1024
RUNTIMES = ("auto", "torch", "onnx")
DEVICES = ("auto", "cpu", "cuda", "mps")


def check_versions(meta: dict, path) -> None:
    """UserError unless ``meta`` (a checkpoint's or an ONNX export's plain data) was made for this SSGI's channel
    spec and normalisation, of a one-render kind, a target and a network variant it has."""
    ch.refuse_gone_model(meta["inputs"], path)
    ch.refuse_gone_target(meta["arch"], path)
    fv, nv = meta.get("format_version"), (meta.get("normalization") or {}).get("version")
    if fv != ch.FORMAT_VERSION or nv != normalize.DESCRIPTION["version"]:
        raise UserError(f"{path}: model was trained on channel spec v{fv} with normalisation v{nv}; this SSGI reads "
                        f"v{ch.FORMAT_VERSION} with v{normalize.DESCRIPTION['version']}: retrain it or update SSGI")
    variants.check_known(meta.get("arch"), path)


def overlap(receptive_field: int, multiple: int) -> int:
    """Tile overlap (each side) that makes tiled inference equal to untiled: >= the receptive field, rounded
    up to the network's size multiple."""
    return int(math.ceil(receptive_field / multiple) * multiple)


def tile_plan(h: int, w: int, tile: int | None, multiple: int, ov: int):
    """The tiles of an ``h`` x ``w`` image (both multiples of ``multiple``): a list of
    ``(core_rows, core_cols, window_rows, window_cols)`` slices; one whole-image tile when it is small. Each
    window is its core extended by ``ov`` on every side (clipped to the image) and starts on a multiple."""
    if tile is None or (h <= tile + 2 * ov and w <= tile + 2 * ov):
        return [(slice(0, h), slice(0, w), slice(0, h), slice(0, w))]
    tile = max(multiple, (int(tile) // multiple) * multiple)
    plan = []
    for y0 in range(0, h, tile):
        y1 = min(h, y0 + tile)
        for x0 in range(0, w, tile):
            x1 = min(w, x0 + tile)
            plan.append((slice(y0, y1), slice(x0, x1), slice(max(0, y0 - ov), min(h, y1 + ov)),
                         slice(max(0, x0 - ov), min(w, x1 + ov))))
    return plan


def run_tiled(forward, x: np.ndarray, tile: int | None, multiple: int, ov: int) -> np.ndarray:
    """``forward(x)`` for a 1 x C x H x W float32 array, padded to ``multiple`` (edge) and in tiles of
    ``tile`` core pixels; 1 x 3 x H x W float32. ``forward`` gets views (any strides): it makes the memory
    layout its runtime wants."""
    h, w = x.shape[-2:]
    ph, pw = (-h) % multiple, (-w) % multiple
    xp = x
    if ph or pw:  # np.pad(mode="edge")'s values and layout, 3x faster (one copy, the edge rows and columns after)
        xp = np.empty(x.shape[:2] + (h + ph, w + pw), x.dtype)
        xp[..., :h, :w] = x
        xp[..., h:, :w] = x[..., h - 1:h, :]
        xp[..., :, w:] = xp[..., :, w - 1:w]
    plan = tile_plan(xp.shape[-2], xp.shape[-1], tile, multiple, ov)
    if len(plan) == 1:
        out = forward(xp)
    else:
        out = np.empty((x.shape[0], 3) + xp.shape[-2:], np.float32)
        for ry, rx, wy, wx in plan:
            o = forward(xp[..., wy, wx])
            out[..., ry, rx] = o[..., ry.start - wy.start:ry.stop - wy.start, rx.start - wx.start:rx.stop - wx.start]
    return out[..., :h, :w]


class ContractPredictor:
    """A loaded model: ``predict(groups)`` -> HxWx3 float32 linear HDR RGB, finite, >= 0, any size (a ref_combined
    model: the signed part it adds to EEVEE's image, ``combined_part``).

    ``groups``: {group name: HxWxC float32} holding at least ``required`` (the stored groups the input spec
    needs). Non-finite inputs are repaired by normalize's rule; ``last_repaired`` holds the pixel count.
    The output is clamped to [0, OUTPUT_BOUND * max(1, brightest value of the input light groups)], and is 0
    where the input albedo is black (diffuse surfaces with zero albedo reflect nothing; the demod/residual
    heads do this by construction, the plain log head needs the rule).
    Subclasses set ``multiple``, ``receptive_field`` and ``runtime``, and define ``_forward``."""

    runtime = "none"
    device = "cpu"

    def __init__(self, meta: dict, path=None, tile: int | None = DEFAULT_TILE):
        self.meta = meta
        self.ckpt = meta  # the checkpoint's plain data (older callers read .ckpt)
        self.path = str(path) if path is not None else "model"
        self.spec: tuple[str, ...] = tuple(meta["inputs"])
        self.required: tuple[str, ...] = ch.required_groups(self.spec)
        self.arch = dict(meta["arch"])
        # what it predicts: the whole image ("ref", the first models name none) or the diffuse part
        self.target = ch.check_target(self.arch.get("target", ch.TARGET_GROUP))
        self.kind = meta.get("kind", "network")
        self.tile = tile
        self.last_repaired = 0
        self.last_stats: dict | None = None

    @property
    def inputs(self) -> tuple[str, ...]:
        return self.spec

    @property
    def best(self) -> dict:
        return dict(self.meta.get("best", {}))

    @property
    def overlap(self) -> int:
        return overlap(self.receptive_field, self.multiple)

    def _forward(self, x: np.ndarray) -> np.ndarray:  # 1xCxHxW normalised -> 1x3xHxW linear
        raise NotImplementedError

    def check_groups(self, groups) -> None:
        missing = normalize.missing_groups(self.spec, groups)
        if missing:
            raise UserError(f"{self.path}: model input spec {ch.format_spec(self.spec)} needs group(s) "
                            f"{', '.join(missing)}, which the input lacks (it has: {', '.join(sorted(groups)) or 'none'})")
        shapes = {tuple(np.shape(groups[g])[:2]) for g in self.required}
        if len(shapes) != 1:
            raise UserError(f"{self.path}: input groups have different sizes {sorted(shapes)}")

    def predict(self, groups: dict[str, np.ndarray], tile: int | None = -1, stats: dict | None = None) -> np.ndarray:
        """``stats``: ``normalize.image_stats`` of the whole image when ``groups`` are a crop of it."""
        self.check_groups(groups)
        x, self.last_repaired, used = normalize.inputs_and_stats(groups, self.spec, stats)
        self.last_stats = used  # the whole-image values of this input (normalize.image_stats)
        x = x.transpose(2, 0, 1)[None]  # HxWxC memory: a channels-last view of 1xCxHxW
        out = run_tiled(self._forward, x, self.tile if tile == -1 else tile, self.multiple, self.overlap)
        lin = np.ascontiguousarray(out[0].transpose(1, 2, 0), dtype=np.float32)
        lin = finish(lin, groups, self.spec, self.required, used)
        if self.target == ch.COMBINED_TARGET:
            return combined_part(lin, groups)
        return lin


def combined_part(image: np.ndarray, groups: dict) -> np.ndarray:
    """A ref_combined model's prediction from its network's whole image (HxWx3, in place): the part it adds to
    EEVEE's GI-off Combined image (signed), 0 where the albedo is black (the head keeps that image there)."""
    c = np.nan_to_num(np.asarray(groups["eevee_combined"], np.float32)[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
    image -= c
    image[~(np.asarray(groups["albedo"]) > 0).any(axis=-1)] = 0.0
    return image


def finish(lin: np.ndarray, groups: dict, spec: tuple[str, ...], required: tuple[str, ...],
           stats: dict | None = None) -> np.ndarray:
    """Step 4: bound ``lin`` (HxWx3, in place) and zero it where the albedo is black. ``stats``: the statistics
    vectors the input used (normalize.inputs_and_stats), read instead of deriving them again (two sorts of the
    image's pixels: 0.1 s of a 480x270 prediction)."""
    lights = [g for g in spec if ch.GROUPS.get(g) is None or ch.GROUPS[g].kind == "light"]
    if lights:
        stats = stats or {}
        rep, _ = normalize.repair({g: groups[g] for g in ch.required_groups(tuple(g for g in lights if g not in stats))})

        def top(g):
            a = stats[g] if g in stats else normalize.derived(g, rep) if g in ch.DERIVED else rep[g]
            return float(np.max(a, initial=0.0))

        peak = max(top(g) for g in lights)
        np.minimum(lin, np.float32(OUTPUT_BOUND * max(1.0, peak)), out=lin)
    if "albedo" in required:
        lin[~(np.asarray(groups["albedo"]) > 0).any(axis=-1)] = 0.0
    return lin
