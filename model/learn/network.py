"""The networks (torch, bpy-free): the seed's ``fssgi`` and leaner variants, rebuilt from a stored architecture.

Every network maps the normalised input tensor (N x C x H x W, ``normalize.to_inputs``) to the prediction in
LOSS SPACE: ``log1p`` of linear HDR RGB (N x 3 x H x W). ``to_linear`` maps it back (expm1, clamped to
[0, expm1(LOG_MAX)]). How the last conv's output ``o`` becomes that prediction is the *head*:

    log       prediction = o                                      (the seed's plain regression, in log space)
    demod     shading s = relu(o);  prediction = log1p(albedo * expm1(s))          (needs albedo in inputs)
    residual  s = relu(log1p(direct) + o); prediction = log1p(albedo * expm1(s))   (needs albedo, direct)
    residual_combined  (target ref_combined: no Diffuse Direct pass, only EEVEE's GI-off Combined image C)
              b = C / max(albedo, ALBEDO_FLOOR) (the light C would be on a diffuse surface); s = relu(log1p(b) + o);
              prediction = log1p(max(C + albedo * (expm1(s) - b), 0))   (needs albedo, eevee_combined)
              o = 0 is EEVEE's image itself; albedo 0 (metal, glass, sky) keeps C exactly; the light the network
              adds, albedo * (expm1(s) - b), may be negative (down to -C where the albedo is above the floor).
    residual_combined_gloss  as residual_combined with albedo + gloss (EEVEE's Glossy Color pass, clamped to 1) in
              place of albedo: metal, whose albedo is 0, takes light too (the reflections of the room a GI-off
              render lacks). Needs gloss in the inputs as well.

``demod``/``residual`` predict the irradiance ("shading") and multiply by albedo: an all-black albedo gives
exactly 0, and ``residual`` starts from the direct light (o = 0 is the local-illumination image).

Backbones:
    fssgi  the seed (Peng 2019): ``pre`` 3x3 convs at ``width`` (the first from C), concatenate the input,
           ``post`` 3x3 convs at ``width`` (the first from width+C), a 3x3 conv to 3. LeakyReLU 0.1, zero
           padding. width=64, pre=4, post=3 with 13 inputs = 238,339 parameters.
    unet   a small encoder-decoder: level 0 at full resolution, each further level halves the size with a
           stride-2 3x3 conv; 2x2 stride-2 transposed convs go back up, concatenated with the skip (and the
           input at level 0), then a 3x3 conv. A large receptive field at a fraction of fssgi's cost.

``VARIANTS`` names complete default architectures; ``arch_for(variant, inputs, **overrides)`` makes the
architecture dict a checkpoint stores and ``build(arch)`` rebuilds the module from it.
"""
from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from .. import channels as ch
from . import variants
from ..errors import UserError
from ..normalize import layout

LOG_MAX = 20.0  # expm1(20) = 4.9e8: far above any real light, far below float32 overflow
ARCH_VERSION = 1

VARIANTS = variants.VARIANTS
DEFAULT_VARIANT = variants.DEFAULT


def _act():
    return nn.LeakyReLU(0.1)


# the input groups each head reads itself (fit never drops them)
HEAD_NEEDS = {"log": (), "demod": ("albedo",), "residual": ("albedo", "direct"),
              # one-render models: from EEVEE's GI-off Combined image (no Diffuse Direct pass: target ref_combined)
              "residual_combined": ("albedo", "eevee_combined"),
              # ... with the Glossy Color pass beside the albedo: metal takes light too
              "residual_combined_gloss": ("albedo", "eevee_combined", "gloss")}
ALBEDO_FLOOR = ch.COMBINED_ALBEDO_FLOOR  # residual_combined: the albedo C / albedo is divided by at least

class Head(nn.Module):
    def __init__(self, kind: str, spec: tuple[str, ...]):
        super().__init__()
        lay = layout(spec)
        need = HEAD_NEEDS
        if kind not in need:
            raise UserError(f"unknown head {kind!r}; known: {', '.join(need)}")
        missing = [g for g in need[kind] if g not in lay]
        if missing:
            raise UserError(f"head {kind!r} needs input group(s) {', '.join(missing)} in the input spec {','.join(spec)}")
        self.kind = kind
        self.alb = (lay["albedo"].start, lay["albedo"].stop) if "albedo" in lay else None
        base = need[kind][1] if kind.startswith("residual") else "direct"
        self.dir = (lay[base].start, lay[base].stop) if base in lay else None
        self.gls = (lay["gloss"].start, lay["gloss"].stop) if kind == "residual_combined_gloss" else None

    def forward(self, o: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        if self.kind == "log":
            return o
        if self.kind in ("residual_combined", "residual_combined_gloss"):
            albedo = x[:, self.alb[0]:self.alb[1]]
            if self.gls is not None:
                albedo = (albedo + x[:, self.gls[0]:self.gls[1]]).clamp_max(1.0)
            c = torch.expm1(x[:, self.dir[0]:self.dir[1]])  # the input holds log1p(C)
            b = c / albedo.clamp_min(ALBEDO_FLOOR)
            s = torch.relu(torch.log1p(b) + o).clamp_max(LOG_MAX)
            return torch.log1p(torch.relu(c + albedo * (torch.expm1(s) - b)))
        # (the other heads' ops in this order: the shipped ONNX export is re-made byte for byte, tests/unit/test_onnx.py)
        s = o
        if self.kind.startswith("residual"):
            s = s + x[:, self.dir[0]:self.dir[1]]
        s = torch.relu(s).clamp_max(LOG_MAX)
        albedo = x[:, self.alb[0]:self.alb[1]]
        return torch.log1p(albedo * torch.expm1(s))


class FSSGI(nn.Module):
    def __init__(self, in_ch: int, spec, width=64, pre=4, post=3, head="log"):
        super().__init__()
        if pre < 1 or post < 1 or width < 1:
            raise UserError(f"fssgi needs pre >= 1, post >= 1, width >= 1 (got {pre}, {post}, {width})")
        a = [nn.Conv2d(in_ch, width, 3, padding=1), _act()]
        for _ in range(pre - 1):
            a += [nn.Conv2d(width, width, 3, padding=1), _act()]
        b = [nn.Conv2d(width + in_ch, width, 3, padding=1), _act()]
        for _ in range(post - 1):
            b += [nn.Conv2d(width, width, 3, padding=1), _act()]
        b += [nn.Conv2d(width, 3, 3, padding=1)]
        self.features = nn.Sequential(*a)
        self.reconstruct = nn.Sequential(*b)
        self.head = Head(head, spec)
        self.multiple = 1
        self.receptive_field = 1 + 2 * (pre + post + 1)

    def forward(self, x):
        o = self.reconstruct(torch.cat([self.features(x), x], dim=1))
        return self.head(o, x)


class UNet(nn.Module):
    def __init__(self, in_ch: int, spec, widths=(16, 32, 64), convs=(1, 2, 2), head="residual"):
        super().__init__()
        widths, convs = list(widths), list(convs)
        if len(widths) != len(convs) or not widths or min(convs) < 1 or min(widths) < 1:
            raise UserError(f"unet needs equal-length widths and convs, each >= 1 (got {widths}, {convs})")
        L = len(widths)
        self.enc = nn.ModuleList()
        for i, (w, n) in enumerate(zip(widths, convs)):
            cin = in_ch if i == 0 else widths[i - 1]
            layers = [nn.Conv2d(cin, w, 3, stride=1 if i == 0 else 2, padding=1), _act()]
            for _ in range(n - 1):
                layers += [nn.Conv2d(w, w, 3, padding=1), _act()]
            self.enc.append(nn.Sequential(*layers))
        self.up = nn.ModuleList()
        self.dec = nn.ModuleList()
        for i in range(L - 1, 0, -1):
            w = widths[i - 1]
            self.up.append(nn.Sequential(nn.ConvTranspose2d(widths[i], w, 2, stride=2), _act()))
            cin = 2 * w + (in_ch if i == 1 else 0)
            self.dec.append(nn.Sequential(nn.Conv2d(cin, w, 3, padding=1), _act()))
        self.out = nn.Conv2d(widths[0], 3, 3, padding=1)
        self.head = Head(head, spec)
        self.multiple = 2 ** (L - 1)
        # receptive field (full width, input pixels) of the deepest path
        r, j = 1 + 2 * convs[0], 1
        for i in range(1, L):
            r += 2 * j
            j *= 2
            r += 2 * j * (convs[i] - 1)
        for _ in range(L - 1):
            j //= 2
            r += 2 * j
        self.receptive_field = r + 2

    def forward(self, x):
        h, w = x.shape[-2:]
        m = self.multiple
        ph, pw = (-h) % m, (-w) % m
        xin = F.pad(x, (0, pw, 0, ph), mode="replicate") if (ph or pw) else x
        skips = []
        y = xin
        for enc in self.enc:
            y = enc(y)
            skips.append(y)
        for k, (up, dec) in enumerate(zip(self.up, self.dec)):
            i = len(self.enc) - 1 - k  # level we come from
            y = up(y)
            parts = [y, skips[i - 1]] + ([xin] if i == 1 else [])
            y = dec(torch.cat(parts, dim=1))
        o = self.head(self.out(y), xin)
        return o[..., :h, :w] if (ph or pw) else o


class PixelLinear(nn.Module):
    """The per-pixel linear regression baseline (``baseline.py`` fits it in closed form): a 1x1 conv of the
    normalised inputs plus a constant. ``space`` is where it regresses: ``linear`` RGB (the seed's) or
    ``log`` (log1p RGB, the loss space)."""

    def __init__(self, in_ch: int, spec, space="linear"):
        super().__init__()
        if space not in ("linear", "log"):
            raise UserError(f"linear baseline space must be 'linear' or 'log', not {space!r}")
        self.conv = nn.Conv2d(in_ch, 3, 1)
        self.space = space
        self.multiple = 1
        self.receptive_field = 1

    def forward(self, x):
        o = self.conv(x)
        if self.space == "linear":
            return torch.log1p(torch.relu(o).clamp_max(math.expm1(LOG_MAX)))
        return o


def box_levels(box: int, width: int, ref_width: int) -> int:
    """The doubling steps of a box of 2**``box`` pixels at ``ref_width``, for an image ``width`` pixels wide: the
    same share of the image (the power of two nearest to it), at least 0."""
    return max(0, int(round(box + math.log2(max(1, width) / max(1, ref_width)))))


def box_shift(level: int) -> int:
    """The shift of doubling step ``level`` (0, 1, ...): 1, -2, 4, -8, ...; the alternating signs keep the box
    nearly centred on its pixel ({-5..10} after four steps)."""
    return (1 << level) * (1 if level % 2 == 0 else -1)


def _shift(a: torch.Tensor, dx: int, dy: int) -> torch.Tensor:
    """Blender's Translate node by (dx, dy) pixels (x right, y up), zeros outside: out[r, c] = a[r + dy, c - dx]."""
    h, w = a.shape[-2:]
    p = F.pad(a, (max(dx, 0), max(-dx, 0), max(-dy, 0), max(dy, 0)))
    y0, x0 = max(-dy, 0) + dy, max(dx, 0) - dx
    return p[..., y0:y0 + h, x0:x0 + w]


class BoxMLP(nn.Module):
    """A per-pixel MLP (1x1 convs, ReLU) over the inputs and the log1p of box means of the GI-off image
    (``eevee_combined``, linear) at a few scales: every box is a chain of shifted adds (zeros outside the image),
    every layer a per-pixel multiply-add, so the whole network compiles into Blender's compositor nodes
    (model/compile). ``boxes``: each box's size as a power of two at ``ref_width`` pixels wide (the width it was
    trained at); at another width the boxes keep their share of the image (``box_levels``). ``passes``: each box
    filter applied that many times along each axis (2: a tent, whose light fades instead of ending in a square
    edge). Train on whole images (a crop's boxes differ from the image's near its edges)."""

    def __init__(self, in_ch: int, spec, widths=(24, 24), boxes=(1, 3, 5, 7), ref_width=240, passes=1,
                 head="residual_combined"):
        super().__init__()
        lay = layout(spec)
        if "eevee_combined" not in lay:
            raise UserError(f"boxmlp needs eevee_combined in the input spec {','.join(spec)}")
        if not widths or min(widths) < 1 or any(b < 0 for b in boxes):
            raise UserError(f"boxmlp needs widths >= 1 and boxes >= 0 (got {widths}, {boxes})")
        self.comb = (lay["eevee_combined"].start, lay["eevee_combined"].stop)
        self.boxes, self.ref_width, self.passes = [int(b) for b in boxes], int(ref_width), int(passes)
        if self.passes < 1:
            raise UserError(f"boxmlp needs passes >= 1 (got {passes})")
        layers, cin = [], in_ch + 3 * len(self.boxes)
        for w in widths:
            layers += [nn.Conv2d(cin, w, 1), nn.ReLU()]
            cin = w
        layers.append(nn.Conv2d(cin, 3, 1))
        self.mlp = nn.Sequential(*layers)
        self.head = Head(head, spec)
        self.multiple = 1
        self.receptive_field = 1 << 20  # whole-image boxes: one tile, never tiled

    def box_means(self, x: torch.Tensor) -> list[torch.Tensor]:
        """log1p of each box's mean of the linear GI-off image (zeros outside the image)."""
        c = torch.expm1(x[:, self.comb[0]:self.comb[1]])
        levels = [box_levels(b, x.shape[-1], self.ref_width) for b in self.boxes]
        out, bx = [], c
        for k in range(max(levels) + 1):
            if k in levels:
                by = bx
                for _ in range(self.passes - 1):
                    for j in range(k):
                        by = by + _shift(by, box_shift(j), 0)
                for _ in range(self.passes):
                    for j in range(k):
                        by = by + _shift(by, 0, box_shift(j))
                out.append(torch.log1p(torch.relu(by * (1.0 / (1 << (2 * k * self.passes))))))
            if k < max(levels):
                bx = bx + _shift(bx, box_shift(k), 0)
        return [out[sorted(set(levels)).index(lv)] for lv in levels]

    def forward(self, x):
        o = self.mlp(torch.cat([x] + self.box_means(x), dim=1))
        return self.head(o, x)


BACKBONES = {"fssgi": (FSSGI, ("width", "pre", "post", "head")),
             "unet": (UNet, ("widths", "convs", "head")),
             "linear": (PixelLinear, ("space",)),
             "boxmlp": (BoxMLP, ("widths", "boxes", "ref_width", "passes", "head"))}


def target_of(arch: dict) -> str:
    """What a network predicts (``channels.TARGETS``): its architecture's "target"; "ref" (the whole image)
    for the first networks, which name none."""
    return ch.check_target(arch.get("target", ch.TARGET_GROUP))


def arch_for(variant: str, inputs=ch.DEFAULT_INPUTS, target: str = ch.TARGET_GROUP, **overrides) -> dict:
    """The complete architecture dict of ``variant`` with ``overrides`` (e.g. width=32), predicting
    ``target``."""
    if variant not in VARIANTS:
        raise UserError(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}")
    a = dict(VARIANTS[variant])
    for k, v in overrides.items():
        if v is None:
            continue
        if k not in BACKBONES[a["backbone"]][1]:
            raise UserError(f"variant {variant!r} has no setting {k!r}; it has {', '.join(BACKBONES[a['backbone']][1])}")
        a[k] = v
    return dict(arch_version=ARCH_VERSION, variant=variant, inputs=list(ch.parse_spec(inputs)),
                target=ch.check_target(target), **a)


def build(arch: dict) -> nn.Module:
    """Rebuild a network from its architecture dict (as stored in a checkpoint)."""
    try:
        if arch.get("arch_version") != ARCH_VERSION:
            raise UserError(f"architecture version {arch.get('arch_version')!r} is not {ARCH_VERSION}")
        cls, keys = BACKBONES[arch["backbone"]]
        spec = ch.parse_spec(arch["inputs"])
        kwargs = {k: arch[k] for k in keys if k in arch}
    except KeyError as e:
        raise UserError(f"architecture {arch!r} lacks {e} or names an unknown backbone; known: {', '.join(BACKBONES)}") from None
    net = cls(ch.input_channels(spec), spec, **kwargs)
    net.arch = dict(arch)
    return net


def count_params(net: nn.Module) -> int:
    return sum(p.numel() for p in net.parameters())


def macs_per_pixel(net: nn.Module, size=(64, 64)) -> float:
    """Multiply-accumulates per output pixel, counted with forward hooks on a probe input."""
    total = [0]

    def hook(mod, inp, out):
        if isinstance(mod, (nn.Conv2d, nn.ConvTranspose2d)):
            k = mod.kernel_size[0] * mod.kernel_size[1]
            cin = mod.in_channels // mod.groups
            if isinstance(mod, nn.Conv2d):
                total[0] += out.numel() * cin * k
            else:
                total[0] += inp[0].numel() * mod.out_channels * k

    hs = [m.register_forward_hook(hook) for m in net.modules()]
    try:
        with torch.inference_mode():
            net(torch.zeros(1, in_channels(net), *size))
    finally:
        for h in hs:
            h.remove()
    return total[0] / (size[0] * size[1])


def in_channels(net: nn.Module) -> int:
    return next(m for m in net.modules() if isinstance(m, nn.Conv2d)).in_channels


def to_linear(pred_log: torch.Tensor) -> torch.Tensor:
    """Loss-space prediction -> linear HDR RGB, finite and >= 0."""
    return torch.expm1(torch.nan_to_num(pred_log, nan=0.0).clamp(0.0, LOG_MAX))


def overlap_for(net: nn.Module) -> int:
    """Tile overlap (each side) that makes tiled inference equal to untiled: >= the receptive field,
    rounded up to the network's size multiple."""
    m = getattr(net, "multiple", 1)
    return int(math.ceil(net.receptive_field / m) * m)
