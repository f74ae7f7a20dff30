"""Benchmark: EEVEE's and Cycles' Diffuse Direct of one radius-0 light over a white Lambert plane, against the
analytic value E / pi (E = P / (4 pi) * h / r^3 on the plane; a spot times Blender's smoothstep cone), by ring
of distance from the foot of the light. Orthographic camera looking down, 96x96, Cycles point-sampled.

    .venv/bin/python benchmarks/direct_analytic.py --light POINT --height 0.3
    .venv/bin/python benchmarks/direct_analytic.py --light SPOT --height 0.3 --cone 113 --blend 0.49
"""
import argparse
import math

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import bpy  # noqa: E402
import numpy as np  # noqa: E402

from ssgi.ssgi_addon.blender import passes, room  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--light", choices=["POINT", "SPOT"], default="POINT")
ap.add_argument("--height", type=float, default=0.3, help="light height above the plane (m)")
ap.add_argument("--cone", type=float, default=113.0, help="spot cone angle (deg)")
ap.add_argument("--blend", type=float, default=0.49, help="spot blend")
ap.add_argument("--spp", type=int, default=256)
a = ap.parse_args()
sc = _bootstrap.empty_scene()
N, half = 96, 1.0
bpy.ops.mesh.primitive_plane_add(size=2 * half)
bpy.context.object.data.materials.append(room.diffuse_material("white", (0.8, 0.8, 0.8)))
cam = bpy.data.cameras.new("cam")
cam.type, cam.ortho_scale = "ORTHO", 2 * half
co = bpy.data.objects.new("cam", cam)
sc.collection.objects.link(co)
co.location, sc.camera = (0, 0, 5), co
li = bpy.data.lights.new("L", a.light)
li.energy, li.shadow_soft_size = 10.0, 0.0
if a.light == "SPOT":
    li.spot_size, li.spot_blend = math.radians(a.cone), a.blend
lo = bpy.data.objects.new("L", li)
sc.collection.objects.link(lo)
lo.location = (0, 0, a.height)
passes.set_resolution(sc, N, N)
e = passes.render_gbuffer(sc, ("direct",))["direct"][..., 0]
c = passes.render_cycles(sc, a.spp, seed=1, hard=True, groups=("direct",))["direct"][..., 0]
xs = (np.arange(N) + 0.5) / N * 2 * half - half
X, Y = np.meshgrid(xs, -xs)
r2 = X ** 2 + Y ** 2 + a.height ** 2
an = li.energy / (4 * math.pi) * a.height / r2 ** 1.5 / math.pi
if a.light == "SPOT":
    cs = math.cos(li.spot_size / 2)
    t = (a.height / np.sqrt(r2) - cs) / ((1 - cs) * li.spot_blend) if li.spot_blend > 0 else \
        (a.height / np.sqrt(r2) > cs) * 1.0
    t = np.clip(t, 0, 1)
    an = an * t * t * (3 - 2 * t)
d = np.sqrt(X ** 2 + Y ** 2)
print(f"{a.light} h={a.height}: EEVEE/Cycles {e.sum() / c.sum():.4f}  EEVEE/analytic {e.sum() / an.sum():.4f}  "
      f"Cycles/analytic {c.sum() / an.sum():.4f}")
for lo_, hi_ in [(0, 0.1), (0.1, 0.2), (0.2, 0.4), (0.4, 0.7), (0.7, 1.0), (1.0, 1.5)]:
    m = (d >= lo_) & (d < hi_) & (an > 1e-6)
    if m.any():
        print(f"  ring {lo_}-{hi_} m: EEVEE/analytic {e[m].sum() / an[m].sum():.4f}  "
              f"Cycles/analytic {c[m].sum() / an[m].sum():.4f}")
