"""A small stand-in dataset of real renders for model experiments, until `cli.py bake` lands.

    .venv/bin/python docs/model_minibake.py OUT_DIR FIRST_SEED COUNT [--size 240x135] [--spp 128]

One view per random room (ssgi_addon.room.build_room(seed)): the EEVEE direct-only G-buffer
(ssgi_addon.passes.render_gbuffer) and a Cycles reference (passes.render_cycles, SPP samples + OIDN), written
with model.exrio.write_sample and listed in manifest.json by the dataset contract. Resumable: samples already
in the manifest are skipped; the manifest is rewritten atomically after each sample.
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

from ssgi.model import channels as ch, exrio  # noqa: E402
from ssgi.ssgi_addon import passes, room  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("first", type=int)
ap.add_argument("count", type=int)
ap.add_argument("--size", default="240x135")
ap.add_argument("--spp", type=int, default=128)
a = ap.parse_args()
w, h = (int(v) for v in a.size.split("x"))
out = Path(a.out)
out.mkdir(parents=True, exist_ok=True)
mpath = out / "manifest.json"
m = json.loads(mpath.read_text()) if mpath.is_file() else dict(
    format_version=ch.FORMAT_VERSION, blender_version=bpy.app.version_string, channel_spec=ch.describe(),
    settings=dict(size=[w, h], ref_samples=a.spp, denoise=True, source="docs/model_minibake.py"), samples={})
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
    g.update(passes.render_cycles(scene, a.spp, seed=seed, denoise=True))
    t2 = time.perf_counter()
    exrio.write_sample(out / f"{key}.exr", g)
    m["samples"][key] = dict(seed=seed, scene=f"room-{seed}", camera=0, frame=1,
                             timings=dict(eevee_s=t1 - t0, cycles_s=t2 - t1))
    tmp = out / f".manifest.json.{os.getpid()}.tmp"
    tmp.write_text(json.dumps(m, indent=1))
    os.replace(tmp, mpath)
    print(f"{key}: eevee {t1 - t0:.1f} s, cycles {t2 - t1:.1f} s", file=sys.stderr, flush=True)
