"""The inference contract (bpy-free): stored groups in, linear HDR RGB out (the model's target: the whole image,
or the diffuse part that infer/compose.py adds to EEVEE's own other components).

``load_predictor(path)`` -> ``Predictor``; ``Predictor.predict({group: HxWxC float32})`` -> HxWx3 float32 linear
radiance, finite, >= 0, any size. Everything around the network happens here, in this order, and nowhere else:

1. check the groups (``required``: the stored groups the input spec needs; all the same size);
2. repair and normalise them into the network input (``normalize.to_inputs``: NaN/Inf repair, log1p light,
   scale-free depth with the normals marking the background);
3. run the network in tiles (``tiled_forward``: overlapping tiles whose kept cores equal the untiled result),
   in the chosen precision (``PRECISIONS``);
4. map the output to linear RGB (``network.to_linear``), bound it (``OUTPUT_BOUND`` times the brightest input
   light) and zero it where the albedo is black.

Every consumer calls this: the render path (ssgi_addon/pipeline/render.py), ``cli.py predict``
(infer/predict.py), the benchmark (infer/bench.py), the fit's node scores (learn/fit.py) and the report.

Where later work plugs in:
- a torch-free runtime (ONNX, numpy) replaces step 3 only: a backend with ``forward(x: 1xCxHxW) -> 1x3xHxW``
  built from the checkpoint (``Predictor.net`` today); steps 1, 2 and 4 stay as they are, so every consumer
  gets it by a different ``load_predictor``;
- a temporal filter after prediction wraps ``Predictor.predict``: it sees the groups (motion from depth and
  normals) and the linear output of each frame, and returns the filtered linear output, before the node
  composites the world where nothing was hit.
"""
from __future__ import annotations

import numpy as np
import torch

from .. import channels as ch
from .. import normalize
from ..errors import UserError
from ..learn import checkpoint, network

OUTPUT_BOUND = 64.0  # a prediction never exceeds OUTPUT_BOUND * max(1, brightest input light value)
DEFAULT_TILE = 1024
PRECISIONS = ("fp32", "fp32-cl", "bf16-cl")


def tiled_forward(net, x: torch.Tensor, tile: int | None = DEFAULT_TILE) -> torch.Tensor:
    """``net(x)`` for a 1 x C x H x W input, in tiles of ``tile`` (core) pixels when the image is larger.

    Each tile is extended by ``network.overlap_for(net)`` (>= the receptive field) on every side and starts on
    a multiple of the network's stride, so the kept core of every tile equals the untiled result."""
    H, W = x.shape[-2:]
    m = getattr(net, "multiple", 1)
    ov = network.overlap_for(net)
    if tile is None or (H <= tile + 2 * ov and W <= tile + 2 * ov):
        return net(x)
    tile = max(m, (int(tile) // m) * m)
    ph, pw = (-H) % m, (-W) % m
    xp = torch.nn.functional.pad(x, (0, pw, 0, ph), mode="replicate") if (ph or pw) else x
    Hp, Wp = xp.shape[-2:]
    out = torch.empty(x.shape[0], 3, Hp, Wp, dtype=torch.float32)
    for y0 in range(0, Hp, tile):
        y1 = min(Hp, y0 + tile)
        for x0 in range(0, Wp, tile):
            x1 = min(Wp, x0 + tile)
            a0, a1 = max(0, y0 - ov), min(Hp, y1 + ov)
            b0, b1 = max(0, x0 - ov), min(Wp, x1 + ov)
            o = net(xp[..., a0:a1, b0:b1].contiguous())
            out[..., y0:y1, x0:x1] = o[..., y0 - a0:y1 - a0, x0 - b0:x1 - b0].float()
    return out[..., :H, :W]


class Predictor:
    """A loaded model. ``predict(groups)`` -> HxWx3 float32 linear HDR RGB, finite, >= 0, any size.

    ``groups``: {group name: HxWxC float32} holding at least ``required`` (the stored groups the input spec
    needs). Non-finite inputs are repaired by normalize's rule; ``last_repaired`` holds the pixel count.
    The output is clamped to [0, OUTPUT_BOUND * max(1, brightest value of the input light groups)], and is 0
    where the input albedo is black (diffuse surfaces with zero albedo reflect nothing; the demod/residual
    heads do this by construction, the plain log head needs the rule: issue 7, case 4).
    ``num_threads`` sets torch's (process-wide) thread count before each prediction when given.
    ``precision``: ``fp32-cl`` (default: float32 in channels_last memory format, 1.2-1.6x faster than NCHW
    here, same numbers up to summation order), ``fp32`` (NCHW) or ``bf16-cl`` (convolutions in bfloat16 under
    torch.autocast, using the CPU's AMX units; head and output in float32).
    """

    def __init__(self, net, ckpt: dict, path=None, num_threads: int | None = None, tile: int | None = DEFAULT_TILE,
                 precision: str = "fp32-cl"):
        if precision not in PRECISIONS:
            raise UserError(f"precision must be one of {', '.join(PRECISIONS)}, not {precision!r}")
        self.precision = precision
        if precision != "fp32":
            net = net.to(memory_format=torch.channels_last)
        self.net = net
        self.ckpt = ckpt
        self.path = str(path) if path is not None else "model"
        self.spec: tuple[str, ...] = tuple(ckpt["inputs"])
        self.required: tuple[str, ...] = ch.required_groups(self.spec)
        self.arch = dict(ckpt["arch"])
        self.target = network.target_of(self.arch)  # what it predicts: the whole image or the diffuse part
        self.kind = ckpt.get("kind", "network")
        self.num_threads = num_threads
        self.tile = tile
        self.last_repaired = 0
        self.receptive_field = int(net.receptive_field)

    @property
    def best(self) -> dict:
        return dict(self.ckpt.get("best", {}))

    def check_groups(self, groups) -> None:
        missing = normalize.missing_groups(self.spec, groups)
        if missing:
            raise UserError(f"{self.path}: model input spec {ch.format_spec(self.spec)} needs group(s) "
                            f"{', '.join(missing)}, which the input lacks (it has: {', '.join(sorted(groups)) or 'none'})")

    def predict(self, groups: dict[str, np.ndarray], tile: int | None = -1) -> np.ndarray:
        self.check_groups(groups)
        shapes = {tuple(np.shape(groups[g])[:2]) for g in self.required}
        if len(shapes) != 1:
            raise UserError(f"{self.path}: input groups have different sizes {sorted(shapes)}")
        x, self.last_repaired = normalize.to_inputs(groups, self.spec)
        if self.num_threads:
            torch.set_num_threads(int(self.num_threads))
        xt = torch.from_numpy(x).permute(2, 0, 1)[None]  # HxWxC memory: already channels_last
        xt = xt.contiguous(memory_format=torch.contiguous_format if self.precision == "fp32" else torch.channels_last)
        with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=self.precision == "bf16-cl"):
            out = tiled_forward(self.net, xt, self.tile if tile == -1 else tile)
        with torch.inference_mode():
            lin = network.to_linear(out.float())[0].permute(1, 2, 0).contiguous().numpy()
        lights = [g for g in self.spec if ch.GROUPS.get(g) is None or ch.GROUPS[g].kind == "light"]
        if lights:
            rep, _ = normalize.repair({g: groups[g] for g in ch.required_groups(tuple(lights))})
            peak = max(float(np.max(normalize.derived(g, rep) if g in ch.DERIVED else rep[g], initial=0.0)) for g in lights)
            np.minimum(lin, np.float32(OUTPUT_BOUND * max(1.0, peak)), out=lin)
        if "albedo" in self.required:
            lin[~(np.asarray(groups["albedo"]) > 0).any(axis=-1)] = 0.0
        return np.ascontiguousarray(lin, dtype=np.float32)


def load_predictor(path, num_threads: int | None = None, tile: int | None = DEFAULT_TILE,
                   precision: str = "fp32-cl") -> Predictor:
    ckpt = checkpoint.load(path)
    return Predictor(checkpoint.build_net(ckpt, path), ckpt, path=path, num_threads=num_threads, tile=tile, precision=precision)
