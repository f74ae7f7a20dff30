"""Benchmark: what the GI-off one render's emitter proxies on every side of a planar emitter
give its inputs that the proxies on the open sides only (``direct_light.open_sides``, ``passes.PROXY_SIDES_LOCAL``)
do not: the one render of a local one-render model (``passes.render_gbuffer``: eevee_local, rest, Combined) made
both ways, compared pixel by pixel, with a figure (Combined both sides | open sides | |eevee_local difference| x5,
the top rows where the difference is, 3x).

    .venv/bin/python benchmarks/proxy_sides.py --blend SHOTS/cornell_emissive.blend --frame 25 --size 480x270 \\
        [--png out/proxy_sides_rim.png]

Prints, per group: its mean, the largest and the mean absolute difference, the pixels that differ by more than
1e-3 and the PSNR between the two (peak 1).
"""
from __future__ import annotations

import argparse
import sys

import _bootstrap  # noqa: F401,E402  (the checkout as package ssgi)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import direct_light, passes  # noqa: E402

GROUPS = ("albedo", "eevee_local", "rest")


def tonemap(x: np.ndarray) -> np.ndarray:
    return (np.clip(x / (1.0 + x), 0.0, 1.0) ** (1 / 2.2) * 255).astype(np.uint8)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blend", required=True)
    ap.add_argument("--frame", type=int, default=1)
    ap.add_argument("--size", type=parse_size, default=(480, 270))
    ap.add_argument("--png", default=None, help="write the figure here")
    a = ap.parse_args(argv)
    bpy.ops.wm.open_mainfile(filepath=a.blend)
    sc = bpy.context.scene
    sc.frame_set(a.frame)
    sc.render.resolution_x, sc.render.resolution_y = a.size
    sc.render.resolution_percentage = 100
    print("open sides per emitter:", {o.name: direct_light.open_sides(sc, o) for o, *_ in direct_light.planar_emitters(sc)})
    out = {s: passes.render_gbuffer(sc, GROUPS, proxy_sides=s) for s in ("both", "open")}
    for g in ("eevee_local", "rest", "beauty"):
        x, y = out["both"][g][..., :3], out["open"][g][..., :3]
        d = np.abs(x - y)
        mse = float((d ** 2).mean())
        print(f"{g:12s} mean {x.mean():.4f}  max|d| {d.max():.4f}  mean|d| {d.mean():.6f}  "
              f"pixels >1e-3 {int((d.max(-1) > 1e-3).sum())} of {d.shape[0] * d.shape[1]}  "
              f"PSNR {10 * np.log10(1.0 / max(mse, 1e-20)):.2f} dB")
    if a.png:
        from PIL import Image
        d = np.abs(out["both"]["eevee_local"] - out["open"]["eevee_local"]).max(-1)
        rows = np.nonzero(d.max(1) > 1e-3)[0]
        top = int(min(d.shape[0], (rows.max() + 1 if rows.size else 12) * 4))  # the rows where it differs, and more
        diff = np.repeat((np.clip(d * 5, 0, 1) * 255).astype(np.uint8)[..., None], 3, -1)
        fig = np.concatenate([tonemap(out["both"]["beauty"][:top, :, :3]), tonemap(out["open"]["beauty"][:top, :, :3]),
                              diff[:top]], 0)
        Image.fromarray(fig).resize((fig.shape[1] * 3, fig.shape[0] * 3), Image.NEAREST).save(a.png)
        print("figure:", a.png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
