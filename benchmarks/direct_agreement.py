"""Benchmark: the input test over many closed rooms. EEVEE's 1-sample Diffuse Direct pass against
Cycles' Diffuse Direct with the same hard lights and a black world, as EEVEE/Cycles over the lit pixels, with
Cycles point-sampling its pixels (as the baker's comparison does, ``passes.render_cycles(hard=True)``) and,
with ``--also-filtered``, with Cycles' default 1.5 px pixel filter too (how EEVEE's anti-aliased pass compares with a filtered one).

    .venv/bin/python benchmarks/direct_agreement.py --rooms 51 0 3 2 4 6 7 8 11 13 15 17 21 --also-filtered
"""
import argparse
import json
import sys

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402

from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import passes, room  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--rooms", type=int, nargs="+", default=[51, 0, 3, 2, 4, 6, 7, 8, 11, 13, 15, 17, 21])
ap.add_argument("--spp", type=int, default=256, help="Cycles samples (default 256)")
ap.add_argument("--size", type=parse_size, default=(96, 54))
ap.add_argument("--also-filtered", action="store_true", help="also against Cycles' 1.5 px filter")
a = ap.parse_args()
scene = _bootstrap.empty_scene()


def ratios(e, c):
    lit = (c.max(-1) > 1e-3) | (e.max(-1) > 1e-3)
    m = c.max(-1) > 1e-3
    return dict(total=round(float(e[lit].sum() / c[lit].sum()), 4),
                channels=[round(float(e[lit][:, k].sum() / c[lit][:, k].sum()), 4) for k in range(3)],
                pooled_rel_err=round(float(np.abs(e - c)[m].sum() / c[m].sum()), 4))


worst = 0.0
for r in a.rooms:
    if room.room_params(r)["open_side"]:
        print(f"room {r}: has an open side; the test is for closed rooms, skipped", file=sys.stderr)
        continue
    room.build_room(r, scene)
    passes.set_resolution(scene, *a.size)
    e = passes.render_gbuffer(scene, ("direct",))["direct"]
    row = dict(room=r, lights=sorted(o.data.type for o in scene.objects if o.type == "LIGHT"),
               point_sampled=ratios(e, passes.render_cycles(scene, a.spp, seed=1, hard=True, groups=("direct",))["direct"]))
    if a.also_filtered:
        with passes.hard_lights(scene), passes._direct_only_world(scene):
            c = passes.render_cycles(scene, a.spp, seed=1, groups=("direct",))["direct"]
        row["filtered_1.5px"] = ratios(e, c)
    p = row["point_sampled"]
    worst = max(worst, abs(p["total"] - 1), *(abs(x - 1) for x in p["channels"]))
    print(json.dumps(row), flush=True)
print(f"worst |EEVEE/Cycles - 1| point-sampled, total or channel: {100 * worst:.2f} %", file=sys.stderr)
