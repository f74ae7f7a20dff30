"""Benchmark: EEVEE/Cycles Diffuse Direct of one room, per object (Cycles' Object Index pass), with Cycles'
pixel filter at 1.5 px (its default) or 0.01 px (a point sample at the pixel centre, as EEVEE's 1 sample),
and a PNG: EEVEE | Cycles | difference (red: EEVEE brighter, blue: darker).

    .venv/bin/python benchmarks/direct_per_object.py --room 13 --filter 1.5 --png out/room13.png
"""
import argparse

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from ssgi.ssgi_addon.blender import passes, room  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--room", type=int, default=13)
ap.add_argument("--filter", type=float, default=1.5, help="Cycles pixel filter width (px)")
ap.add_argument("--spp", type=int, default=256)
ap.add_argument("--png", default=None)
a = ap.parse_args()
sc = _bootstrap.empty_scene()
room.build_room(a.room, sc)
passes.set_resolution(sc, 96, 54)
objs = [o for o in sc.objects if o.type == "MESH"]
for i, o in enumerate(objs):
    o.pass_index = i + 1
e = passes.render_gbuffer(sc, ("direct",))["direct"]
passes.configure_cycles(sc, a.spp, seed=1)
sc.cycles.filter_width = a.filter
vl = sc.view_layers[0]
vl.use_pass_diffuse_direct = vl.use_pass_object_index = True
with passes._direct_only_world(sc), passes.hard_lights(sc):
    P = passes._render(sc)
c = passes._group(P, "direct")[..., :3]
idx = np.rint(next(iter(P["Object Index"].values()))).astype(int)
lit = (c.max(-1) > 1e-3) | (e.max(-1) > 1e-3)
print(f"room {a.room}, Cycles filter {a.filter} px: EEVEE/Cycles {e[lit].sum() / c[lit].sum():.4f}")
for i, o in enumerate(objs):
    m = (idx == i + 1) & lit
    if m.sum() >= 5:
        print(f"  {o.name:28s} px {m.sum():5d} share {c[m].sum() / c[lit].sum():.3f} EEVEE/Cycles "
              f"{e[m].sum() / c[m].sum():.4f}  adds {(e[m].sum() - c[m].sum()) / c[lit].sum():+.4f}")
if a.png:
    def tm(x):
        return (np.clip(x / np.percentile(c, 99), 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
    dd = e.mean(-1) - c.mean(-1)
    s = np.abs(dd).max() / 2 + 1e-9
    dm = np.zeros(dd.shape + (3,), np.uint8)
    dm[..., 0], dm[..., 2] = np.clip(dd / s, 0, 1) * 255, np.clip(-dd / s, 0, 1) * 255
    img = np.concatenate([tm(e), tm(c), dm], 1)
    Image.fromarray(img).resize((img.shape[1] * 4, img.shape[0] * 4), Image.NEAREST).save(a.png)
