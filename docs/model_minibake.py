"""A small stand-in dataset of real renders for model experiments, until `cli.py bake` lands.

    .venv/bin/python docs/model_minibake.py OUT_DIR FIRST_SEED COUNT [--size 240x135] [--spp 128]

One view per random room (ssgi_addon.room.build_room(seed)): the EEVEE direct-only G-buffer
(ssgi_addon.passes.render_gbuffer) and a Cycles reference (passes.render_cycles, SPP samples + OIDN), written
with model.exrio.write_sample and listed in manifest.json by the dataset contract. Resumable: samples already
in the manifest are skipped; the manifest is rewritten atomically after each sample.

Exposure: the random rooms come out bright (measured on 40 rooms: the reference's mean over geometry pixels
was 0.14 to 7.1, in most rooms over 60 % of pixels above 1, where the seed's clamped PSNR sees nothing). Light
is linear in the lights' power, so every light group (direct, eevee RGB, ref) of a sample is scaled by one
factor k that puts the 90th percentile of the reference's luminance over geometry pixels at 0.8 (k is stored
as the sample's "exposure"). Samples written without it are rescaled in place on the next run.
"""
import argparse
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import cli  # noqa: E402

pkg = cli.load_package()
import bpy  # noqa: E402
import numpy as np  # noqa: E402

from ssgi.model import channels as ch
from ssgi.model.dataset import exrio  # noqa: E402
from ssgi.ssgi_addon.blender import passes, room  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("first", type=int)
ap.add_argument("count", type=int)
ap.add_argument("--size", default="240x135")
ap.add_argument("--spp", type=int, default=128)
ap.add_argument("--hard", action="store_true",
                help="render the reference with EEVEE's hard lights and a black world (pure GI to learn)")
a = ap.parse_args()
w, h = (int(v) for v in a.size.split("x"))
out = Path(a.out)
out.mkdir(parents=True, exist_ok=True)
mpath = out / "manifest.json"
m = json.loads(mpath.read_text()) if mpath.is_file() else dict(
    format_version=ch.FORMAT_VERSION, blender_version=bpy.app.version_string, channel_spec=ch.describe(),
    settings=dict(size=[w, h], ref_samples=a.spp, denoise=True, hard_reference=a.hard,
                  source="docs/model_minibake.py"), samples={})


def expose(g):
    """Scale the light groups so the reference's 90th-percentile luminance over geometry is 0.8."""
    from ssgi.model import normalize
    geo = images.geometry_mask(g["depth"], g["normal"])
    lum = (g["ref"] @ np.array([0.2126, 0.7152, 0.0722], np.float32))[geo]
    p90 = float(np.percentile(lum, 90)) if lum.size else 0.0
    k = 0.8 / p90 if p90 > 0 else 1.0
    for name in ("direct", "ref"):
        g[name] = g[name] * np.float32(k)
    g["eevee"] = np.concatenate([g["eevee"][..., :3] * np.float32(k), g["eevee"][..., 3:]], -1)
    return k


def save_manifest():
    tmp = out / f".manifest.json.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(m, indent=1))
    os.replace(tmp, mpath)


for key, meta in m["samples"].items():
    if "exposure" not in meta:
        g = exrio.read_sample(out / f"{key}.exr")
        meta["exposure"] = expose(g)
        exrio.write_sample(out / f"{key}.exr", g)
        save_manifest()
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
for seed in range(a.first, a.first + a.count):
    key = f"{seed:06d}"
    if key in m["samples"]:
        continue
    t0 = time.perf_counter()
    room.build_room(seed, scene)
    passes.set_resolution(scene, w, h)
    g = passes.render_gbuffer(scene)
    t1 = time.perf_counter()
    g.update(passes.render_cycles(scene, a.spp, seed=seed, denoise=True, hard=a.hard))
    t2 = time.perf_counter()
    k = expose(g)
    exrio.write_sample(out / f"{key}.exr", g)
    m["samples"][key] = dict(seed=seed, scene=f"room-{seed}", camera=0, frame=1, exposure=k,
                             timings=dict(eevee_s=t1 - t0, cycles_s=t2 - t1))
    save_manifest()
    print(f"{key}: eevee {t1 - t0:.1f} s, cycles {t2 - t1:.1f} s", file=sys.stderr, flush=True)
