"""Benchmark: where the ceiling of a diffuse-part model loses, by kind of pixel.

The ceiling of a diffuse-part model is Cycles' own diffuse part + EEVEE's rest as the node renders it
(passes.render_gbuffer's ``rest``: the scene's samples, the emitter proxies); whatever it loses is EEVEE's rest.
For each --frames frame of the .blend's scene camera this renders that rest, its Glossy Color (``gloss``) and the
G-buffer, and Cycles --spp + OIDN (another seed a frame), and prints the ceiling's PSNR (geometry pixels) and, for
each region, its share of the geometry pixels, its share of the ceiling's squared error (both clamped to [0, 1],
as the PSNR scores) and its mean ceiling - Cycles (RGB):

    mirror/metal/glass  no diffuse colour (albedo < 0.02) and Glossy Color above 0.5 (EEVEE writes no
                        transmission pass, so glass and metal fall here together)
    other dark          no diffuse colour, Glossy Color at most 0.5 (emitters, black surfaces)
    diffuse-coloured    albedo of 0.02 or more in some channel

    .venv/bin/python benchmarks/rest_error.py --blend SHOT.blend --frames 25,34 [--spp 16]
"""
from __future__ import annotations

import argparse
import sys

import _bootstrap  # noqa: F401  (the checkout as package ssgi)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blend", required=True)
    ap.add_argument("--frames", default="1", help="comma-separated frame numbers")
    ap.add_argument("--spp", type=int, default=16, help="Cycles samples of the reference (+ OIDN)")
    a = ap.parse_args(argv)

    import bpy
    import numpy as np

    from ssgi.model import channels as ch, images, metrics
    from ssgi.model.errors import UserError
    from ssgi.model.infer.compose import compose
    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.blendfile import check_blend, open_blend

    try:
        frames = [int(f) for f in a.frames.split(",")]
    except ValueError:
        print(f"rest_error: --frames {a.frames!r}: expected comma-separated integers", file=sys.stderr)
        return 2
    try:
        open_blend(check_blend(a.blend))
    except UserError as e:
        print(f"rest_error: {e}", file=sys.stderr)
        return 2
    scene = bpy.context.scene
    for f in frames:
        scene.frame_set(f)
        g = passes.render_gbuffer(scene, ("albedo", "depth", "normal", "rest", "gloss"))
        mask = images.geometry_mask(g["depth"], g["normal"])
        cy = passes.render_cycles(scene, a.spp, seed=100003 + f, denoise=True, groups=("ref", "ref_diffuse"))
        ref = cy["ref"][..., :3]
        ceiling = compose(cy["ref_diffuse"][..., :3], {"rest": g["rest"]}, ch.DIFFUSE_TARGET)
        err = ((np.clip(ceiling, 0, 1) - np.clip(ref, 0, 1)) ** 2).sum(-1)
        dark = g["albedo"][..., :3].max(-1) < 0.02
        glossy = g["gloss"][..., :3].max(-1) > 0.5
        psnr = metrics.score(ceiling, ref, mask, with_ssim=False, with_flip=False)["psnr"]
        print(f"frame {f}: ceiling {psnr:.2f} dB over {int(mask.sum())} geometry pixels", flush=True)
        for name, m in (("mirror/metal/glass", dark & glossy), ("other dark", dark & ~glossy),
                        ("diffuse-coloured", ~dark)):
            m = m & mask
            mean = (ceiling - ref)[m].mean(0) if m.any() else np.zeros(3)
            print(f"  {name:18s} pixels {m.sum() / mask.sum():6.1%}  squared error {err[m].sum() / err[mask].sum():6.1%}"
                  f"  mean ceiling - Cycles {mean[0]:+.3f} {mean[1]:+.3f} {mean[2]:+.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
