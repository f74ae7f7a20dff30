"""Probe (session 28): EEVEE with ray tracing on only for smooth closures (trace_max_roughness) and fast GI off: does it
give EEVEE GI's reflections and refraction on metal and glass and the GI-off image on diffuse surfaces, and what does
it cost? Run: .venv/bin/python docs/one_render/s28/rt_probe.py STUDIO.blend ROUNDS OUT.png (STUDIO.blend from
benchmarks/artist_scenes.py). Studio, 480x270, 16 samples, CPU s of the process per render (warm), alternating rounds."""
import json, sys, time
import numpy as np
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[3])); import cli; cli.load_package()  # the repository root
import bpy
from ssgi.ssgi_addon.blender import passes
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
sc = bpy.context.scene
W, H = 480, 270
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = W, H, 100
sc.eevee.taa_render_samples = 16
passes.no_light_culled(sc)
CONF = {"gi": (True, True, None), "off": (False, False, None), "rt_only_05": (True, False, 0.5),
        "rt_only_01": (True, False, 0.1)}
def render(k):
    rt, fg, mr = CONF[k]
    sc.eevee.use_raytracing, sc.eevee.use_fast_gi = rt, fg
    if mr is not None:
        sc.eevee.ray_tracing_options.trace_max_roughness = mr
    t0 = time.process_time()
    p = passes._render(sc)
    cpu = time.process_time() - t0
    img = np.stack([p["Combined"][c] for c in "RGB"], -1)
    return img, cpu
imgs, cpus = {}, {k: [] for k in CONF}
for k in CONF:
    imgs[k] = render(k)[0]  # warm-up (shader compile)
for r in range(int(sys.argv[2])):
    for k in CONF:
        imgs[k], c = render(k)
        cpus[k].append(round(c, 2))
# regions: albedo ~0 (metal, glass: what the network cannot correct) and the rest
g = passes.render_gbuffer(sc, ("albedo", "depth", "normal"), samples=1)
alb = g["albedo"][..., :3].max(-1)
geo = g["depth"][..., 0] < 0.999 * sc.camera.data.clip_end
dark, diff = geo & (alb < 0.05), geo & (alb >= 0.05)
def mad(a, b, m):
    return float(np.abs(a - b)[m].mean())
res = {"cpu_s": cpus, "pixels_dark": int(dark.sum()), "pixels_diffuse": int(diff.sum())}
for k in ("rt_only_05", "rt_only_01", "off"):
    res[k] = {"dark_vs_gi": mad(imgs[k], imgs["gi"], dark), "dark_vs_off": mad(imgs[k], imgs["off"], dark),
              "diffuse_vs_gi": mad(imgs[k], imgs["gi"], diff), "diffuse_vs_off": mad(imgs[k], imgs["off"], diff)}
print("RESULT", json.dumps(res))
from PIL import Image
tm = lambda x: (np.clip((np.maximum(x, 0) / (1 + np.maximum(x, 0))) ** (1 / 2.2), 0, 1) * 255).astype(np.uint8)
Image.fromarray(tm(np.concatenate([imgs[k] for k in CONF], 1))).save(sys.argv[3])
