"""A ``boxmlp`` network and its inference contract as a short list of image operations (bpy-free, numpy only).

The list is what Blender's compositor evaluates (ssgi_addon/blender/compiled.py builds one node per step) and
what ``evaluate`` computes with numpy, so that the two can be compared pixel for pixel. Every value is an HxWxC
float32 image; the operations are the ones the compositor has at its per-pixel or shift cost:

    input    name                    a render pass: image (Combined RGB), albedo (Diffuse Color), normal (world)
    param    name                    a per-frame constant 3-vector (camera rotation rows, the world's coefficients)
    clamp    src, lo, hi             per channel
    log1p    src / expm1 src         per channel (the compositor: log(x + 1), exp(x) - 1)
    shift    src, dx, dy             Blender's Translate: out[r, c] = src[r + dy, c - dx], zeros outside
    add, sub, mul, div, max  a, b    per channel; b is a value or a number
    lincomb  src, params, bias       sum_i src[..., i] * param_i (+ bias param): a 3x3 turn or the world's light
    masklen  src, by, t              src where |by| > t, else 0
    affine   srcs, W, b              per pixel: W @ concat(srcs) + b (a 1x1 conv)
    relu     src

``add(a, b)`` with a shifted ``b`` keeps ``a``'s pixel grid: the compositor evaluates a node on the grid of its
first input, so the graph never puts a shifted value first.

``from_checkpoint`` makes the list for an image ``width`` pixels wide (the boxes keep their share of the image);
``frame_params`` gives the per-frame constants from the camera's rotation and the world's L1 coefficients.
The result is the frame the extension's own path shows for that model: EEVEE's GI-off image plus the light the
network adds (``compose``), with the contract's normalisation (repair clamps, log1p of light, camera-space normals,
the ``sky`` group from the normal) inside. Not in the list: NaN repair (a render pass holds none) and the
contract's output bound (64 x the brightest input light: never reached by a finite image of this head).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import channels as ch
from .. import sky as sky_model
from ..errors import UserError

LIGHT_MAX = 65504.0  # normalize.LIGHT_MAX
LOG_MAX = 20.0  # network.LOG_MAX
PASSES = {"image": "Image", "albedo": "Diffuse Color", "normal": "Normal"}  # graph input -> Render Layers output
SPEC = ("albedo", "normal", "eevee_combined", "sky")  # the inputs a compiled model reads, in this order
PARAMS = ("rot0", "rot1", "rot2", "sky0", "sky1", "sky2", "sky3")


@dataclass
class Op:
    op: str
    out: str
    args: tuple
    kw: dict = field(default_factory=dict)


@dataclass
class Graph:
    ops: list[Op]
    output: str
    width: int
    meta: dict

    def count(self, op: str) -> int:
        return sum(1 for o in self.ops if o.op == op)


class _Builder:
    def __init__(self):
        self.ops: list[Op] = []
        self.n = 0

    def __call__(self, op: str, *args, **kw) -> str:
        self.n += 1
        name = f"{op}{self.n}"
        self.ops.append(Op(op, name, args, kw))
        return name


def box_means(g: _Builder, c: str, levels: list[int], passes: int = 1) -> list[str]:
    """log1p of the mean of ``c`` over boxes of 2**level pixels a side, each applied ``passes`` times along each axis
    (doubling chains of shifted adds, zeros outside: network.BoxMLP.box_means)."""
    from ..learn.network import box_shift  # (torch is imported there: only when compiling a checkpoint)

    made, bx = {}, c
    for k in range(max(levels) + 1):
        if k in levels:
            by = bx
            for _ in range(passes - 1):
                for j in range(k):
                    by = g("add", by, g("shift", by, box_shift(j), 0))
            for _ in range(passes):
                for j in range(k):
                    by = g("add", by, g("shift", by, 0, box_shift(j)))
            made[k] = g("log1p", g("max", g("mul", by, 1.0 / (1 << (2 * k * passes))), 0.0))
        if k < max(levels):
            bx = g("add", bx, g("shift", bx, box_shift(k), 0))
    return [made[k] for k in levels]


def check_compilable(arch: dict, path) -> None:
    if arch.get("backbone") != "boxmlp":
        raise UserError(f"{path}: a {arch.get('variant', arch.get('backbone'))} network does not compile into "
                        f"compositor nodes; train one with `cli.py train --variant boxmlp --inputs {','.join(SPEC)} "
                        f"--target {ch.COMBINED_TARGET}` (docs/compiled.md)")
    if tuple(arch.get("inputs", ())) != SPEC or arch.get("head") != "residual_combined":
        raise UserError(f"{path}: a compiled model reads inputs {','.join(SPEC)} with head residual_combined; this one "
                        f"has inputs {','.join(arch.get('inputs', ()))} and head {arch.get('head')}")


def from_checkpoint(ckpt: dict, width: int, path="model") -> Graph:
    """The operations of checkpoint ``ckpt`` (checkpoint.load's dict) for an image ``width`` pixels wide."""
    from ..learn.network import box_levels, ALBEDO_FLOOR

    arch = ckpt["arch"]
    check_compilable(arch, path)
    sd = {k: np.asarray(v.detach().cpu().numpy() if hasattr(v, "detach") else v, np.float32)
          for k, v in ckpt["state_dict"].items()}
    g = _Builder()
    img, alb, nrm = g("input", "image"), g("input", "albedo"), g("input", "normal")
    rot = [g("param", f"rot{i}") for i in range(3)]
    skyp = [g("param", f"sky{i}") for i in range(4)]
    c = g("clamp", img, 0.0, LIGHT_MAX)
    a = g("clamp", alb, 0.0, 1.0)
    ncam = g("clamp", g("lincomb", nrm, rot[0], rot[1], rot[2]), -1.0, 1.0)
    # the sky group (model/sky.irradiance): the world's L1 light at the normal, 0 where nothing is hit
    sky = g("masklen", g("max", g("lincomb", nrm, skyp[1], skyp[2], skyp[3], bias=skyp[0]), 0.0), nrm, 0.5)
    feats = [a, ncam, g("log1p", c), g("log1p", g("clamp", sky, 0.0, LIGHT_MAX))]
    feats += box_means(g, c, [box_levels(b, width, arch["ref_width"]) for b in arch["boxes"]], arch.get("passes", 1))
    convs = sorted({int(k.split(".")[1]) for k in sd if k.startswith("mlp.")})
    h = feats
    for i, k in enumerate(convs):
        w, b = sd[f"mlp.{k}.weight"][:, :, 0, 0], sd[f"mlp.{k}.bias"]
        h = g("affine", *h, W=w, b=b)
        if i < len(convs) - 1:
            h = g("relu", h)
        h = [h]
    o = h[0]
    # the head (network.Head residual_combined) and network.to_linear
    bl = g("div", c, g("max", a, ALBEDO_FLOOR))
    s = g("clamp", g("max", g("add", g("log1p", bl), o), 0.0), 0.0, LOG_MAX)
    out = g("max", g("add", c, g("mul", a, g("sub", g("expm1", s), bl))), 0.0)
    out = g("clamp", out, 0.0, float(np.expm1(np.float32(LOG_MAX))))
    meta = dict(arch=dict(arch), width=int(width), boxes=[box_levels(b, width, arch["ref_width"]) for b in arch["boxes"]])
    return Graph(g.ops, out, int(width), meta)


def frame_params(rot: np.ndarray, coef: np.ndarray) -> dict[str, np.ndarray]:
    """The per-frame constants: ``rot`` the camera's rotation (columns its axes in the world: passes.camera_rotation),
    ``coef`` the world's 4x3 L1 coefficients (model/sky.coefficients)."""
    rot, coef = np.asarray(rot, np.float64), np.asarray(coef, np.float64)
    p = {f"rot{i}": rot[i, :] for i in range(3)}  # world normal -> camera: n_cam = sum_i n_world[i] * rot[i, :]
    p["sky0"] = sky_model.Y0 * coef[0]
    p.update({f"sky{i + 1}": sky_model.Y1 * coef[i + 1] for i in range(3)})
    return {k: v.astype(np.float32) for k, v in p.items()}


def _shift(a: np.ndarray, dx: int, dy: int) -> np.ndarray:
    h, w = a.shape[:2]
    out = np.zeros_like(a)
    if abs(dy) >= h or abs(dx) >= w:  # shifted out of the image
        return out
    ys, yd = (slice(dy, h), slice(0, h - dy)) if dy >= 0 else (slice(0, h + dy), slice(-dy, h))
    xs, xd = (slice(0, w - dx), slice(dx, w)) if dx >= 0 else (slice(-dx, w), slice(0, w + dx))
    out[yd, xd] = a[ys, xs]
    return out


def evaluate(graph: Graph, passes: dict[str, np.ndarray], params: dict[str, np.ndarray]) -> np.ndarray:
    """HxWx3 float32: the graph's output for render passes ``passes`` ({"image", "albedo", "normal"}: HxWx>=3,
    top row first, normals in world space) and per-frame constants ``params`` (``frame_params``)."""
    v: dict[str, np.ndarray] = {}
    f32 = np.float32

    def val(x):
        return v[x] if isinstance(x, str) else f32(x)

    for op in graph.ops:
        a = op.args
        if op.op == "input":
            r = np.asarray(passes[a[0]], f32)[..., :3]
        elif op.op == "param":
            r = np.asarray(params[a[0]], f32).reshape(1, 1, 3)
        elif op.op == "clamp":
            r = np.clip(v[a[0]], f32(a[1]), f32(a[2]))
        elif op.op == "log1p":
            r = np.log1p(v[a[0]])
        elif op.op == "expm1":
            r = np.expm1(v[a[0]])
        elif op.op == "shift":
            r = _shift(v[a[0]], int(a[1]), int(a[2]))
        elif op.op in ("add", "sub", "mul", "div", "max"):
            fn = {"add": np.add, "sub": np.subtract, "mul": np.multiply, "div": np.divide, "max": np.maximum}[op.op]
            r = fn(v[a[0]], val(a[1]))
        elif op.op == "lincomb":
            src = v[a[0]]
            r = sum(src[..., i:i + 1] * v[p] for i, p in enumerate(a[1:]))
            if op.kw.get("bias"):
                r = r + v[op.kw["bias"]]
        elif op.op == "masklen":
            r = np.where(np.linalg.norm(v[a[1]], axis=-1, keepdims=True) > f32(a[2]), v[a[0]], f32(0))
        elif op.op == "affine":
            x = np.concatenate([v[s] for s in a], axis=-1)
            r = x @ op.kw["W"].T + op.kw["b"]
        elif op.op == "relu":
            r = np.maximum(v[a[0]], f32(0))
        else:
            raise ValueError(f"unknown operation {op.op!r}")
        v[op.out] = np.asarray(r, f32)
    return v[graph.output]


def contract_groups(passes: dict[str, np.ndarray], rot: np.ndarray, coef: np.ndarray) -> dict[str, np.ndarray]:
    """The input groups the extension's own path gives a compiled model for the same render passes (``evaluate``'s
    ``passes``): camera-space normals (passes.world_to_camera_normals) and the sky group (model/sky.irradiance)."""
    n = np.asarray(passes["normal"], np.float32)[..., :3]
    ncam = np.einsum("hwi,ij->hwj", n.astype(np.float64), np.asarray(rot, np.float64)).astype(np.float32)
    return {"albedo": np.asarray(passes["albedo"], np.float32)[..., :3], "normal": ncam,
            "eevee_combined": np.asarray(passes["image"], np.float32)[..., :3],
            "sky": sky_model.irradiance(coef, ncam, rot)}


def contract_frame(predictor, groups: dict[str, np.ndarray]) -> np.ndarray:
    """HxWx3: the frame the extension's own path shows (the inference contract, then compose) for ``groups``."""
    from ..infer.compose import compose

    return compose(predictor.predict(groups), groups, predictor.target)
