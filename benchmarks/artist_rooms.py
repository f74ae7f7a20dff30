"""Benchmark: light levels and look of artist-mode random scenes (ssgi_addon/blender/room_artist.py).

Per seed: Cycles at --spp (+ OIDN) at --size, the mean linear value over the image and the seconds a render;
a contact sheet (sRGB, the scene kind and mean under each frame) to look at.

    .venv/bin/python benchmarks/artist_rooms.py --seeds 0 1 2 3 4 5 6 7 8 9 10 11 --sheet docs/artist_rooms.png
"""
import argparse
import json
import sys
import time

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402

from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import passes, room  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--seeds", type=int, nargs="+", default=list(range(12)))
ap.add_argument("--size", type=parse_size, default=(240, 135))
ap.add_argument("--spp", type=int, default=32)
ap.add_argument("--cols", type=int, default=4)
ap.add_argument("--sheet", default=None, help="contact sheet PNG")
ap.add_argument("--mode", default="artist", choices=room.MODES)
a = ap.parse_args()


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


scene = _bootstrap.empty_scene()
frames, rows = [], []
for s in a.seeds:
    t0 = time.perf_counter()
    room.build_room(s, scene, mode=a.mode)
    t_build = time.perf_counter() - t0
    prm = room.room_params(s, a.mode)
    passes.set_resolution(scene, *a.size)
    t = time.perf_counter()
    img = passes.render_cycles(scene, a.spp, denoise=True)["ref"]
    dt = time.perf_counter() - t
    mean = float(img.mean())
    row = dict(seed=s, kind=prm.get("kind", "open" if prm.get("open_side") else "closed"),
               lighting=prm.get("lighting", "lamps"), world=prm["world"].get("type", "flat"),
               lights=len(prm["lights"]) + (prm.get("sun") is not None), emitters=len(prm.get("emitters", ())),
               mean=round(mean, 4), clipped=round(float((img.max(axis=-1) > 1.0).mean()), 3),
               seconds=round(dt, 2), build_s=round(t_build, 2))
    rows.append(row)
    print(json.dumps(row), flush=True)
    frames.append((img, f"{s} {row['kind']} {row['lighting']} {mean:.3f}"))

if a.sheet:
    from PIL import Image, ImageDraw
    w, h = a.size
    n = len(frames)
    cols = a.cols
    rws = (n + cols - 1) // cols
    sheet = Image.new("RGB", (cols * w, rws * (h + 14)), (0, 0, 0))
    dr = ImageDraw.Draw(sheet)
    for i, (img, label) in enumerate(frames):
        x, y = (i % cols) * w, (i // cols) * (h + 14)
        sheet.paste(Image.fromarray((srgb(img) * 255 + 0.5).astype(np.uint8)), (x, y))
        dr.text((x + 2, y + h + 1), label, fill=(255, 255, 255))
    sheet.save(a.sheet)
    print("sheet", a.sheet, file=sys.stderr)
means = [r["mean"] for r in rows]
print(json.dumps(dict(n=len(rows), mean_median=round(float(np.median(means)), 4),
                      in_range=sum(0.05 <= m <= 0.6 for m in means),
                      seconds_median=round(float(np.median([r["seconds"] for r in rows])), 2))))
