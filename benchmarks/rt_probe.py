"""Probe: EEVEE with ray tracing on and fast GI off (ray tracing only up to a roughness,
``ray_tracing_options.trace_max_roughness``): does it keep EEVEE GI's reflections and refraction on metal and glass
while diffuse surfaces get the GI-off light, and what does such a render cost against EEVEE GI and GI off? CPU seconds
of the process per render (EEVEE's llvmpipe runs in it), warm (one untimed render of each configuration first), the
configurations alternating round by round; mean absolute differences of the Combined image on black-albedo pixels
(metal, glass: what a combined model's network cannot correct) and on the other geometry pixels.

    .venv/bin/python benchmarks/rt_probe.py --blend S/studio.blend --rounds 2 --out probe.png --json probe.json

(S: ``benchmarks/artist_scenes.py --out S``.) The PNG is the images side by side in ``--configs`` order, tonemapped
x/(1+x), sRGB (by default EEVEE GI | GI off | ray tracing only, max roughness 0.5 | 0.1). Cheaper ways to
keep EEVEE's GI:

    .venv/bin/python benchmarks/rt_probe.py --blend S/studio.blend --rounds 1 \
        --configs gi,off,fast_gi_only,probe_method,trace_eighth,no_denoise
"""
from __future__ import annotations

import argparse
import json
import time

import _bootstrap  # noqa: F401  (the checkout as package ssgi)

# name: (ray tracing, fast GI, trace_max_roughness or None: the scene's, {other EEVEE setting: value},
# {ray_tracing_options setting: value}); the other settings stay the scene's
CONFIGS = {"gi": (True, True, None, {}, {}), "off": (False, False, None, {}, {}),
           "rt_only_05": (True, False, 0.5, {}, {}), "rt_only_01": (True, False, 0.1, {}, {}),
           # cheaper ways to keep EEVEE's GI
           "fast_gi_only": (False, True, None, {}, {}),  # fast GI without ray tracing
           "probe_method": (True, True, None, {"ray_tracing_method": "PROBE"}, {}),  # rays from the light probes
           "trace_eighth": (True, True, None, {"fast_gi_resolution": "8"}, {"resolution_scale": "8"}),
           "no_denoise": (True, True, None, {}, {"use_denoise": False})}
DEFAULT_CONFIGS = ("gi", "off", "rt_only_05", "rt_only_01")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blend", required=True, help="the scene (.blend; its camera and world)")
    ap.add_argument("--size", default="480x270", help="render size WxH (480x270)")
    ap.add_argument("--samples", type=int, default=16, help="EEVEE samples (16)")
    ap.add_argument("--rounds", type=int, default=2, help="timed rounds of every configuration (2)")
    ap.add_argument("--out", default=None, help="write the images side by side here (PNG)")
    ap.add_argument("--json", default=None, help="write the numbers here")
    ap.add_argument("--configs", default=",".join(DEFAULT_CONFIGS),
                    help=f"comma-separated configurations, 'gi' first ({','.join(DEFAULT_CONFIGS)}); known: "
                         f"{','.join(CONFIGS)}")
    a = ap.parse_args()
    names = [c.strip() for c in a.configs.split(",") if c.strip()]
    bad = [c for c in names if c not in CONFIGS]
    if bad or not names or names[0] != "gi":
        ap.error(f"--configs {a.configs!r}: " + (f"unknown {', '.join(bad)}; known: {', '.join(CONFIGS)}" if bad
                                                 else "the first must be 'gi' (the others are compared with it)"))

    import bpy
    import numpy as np
    from ssgi.model.cliargs import parse_size
    from ssgi.model.images import WORLD_DEPTH_FRACTION
    from ssgi.ssgi_addon.blender import passes

    bpy.ops.wm.open_mainfile(filepath=a.blend)
    sc = bpy.context.scene
    w, h = parse_size(a.size)
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = w, h, 100
    sc.eevee.taa_render_samples = a.samples
    passes.no_light_culled(sc)

    ee, rto = sc.eevee, sc.eevee.ray_tracing_options
    own = {n: getattr(ee, n) for c in CONFIGS.values() for n in c[3]}
    own_rt = {n: getattr(rto, n) for c in CONFIGS.values() for n in c[4]}
    own_rt["trace_max_roughness"] = rto.trace_max_roughness

    def render(k):
        rt, fg, mr, extra, extra_rt = CONFIGS[k]
        for n, v in (own | extra).items():
            setattr(ee, n, v)
        for n, v in (own_rt | extra_rt | ({"trace_max_roughness": mr} if mr is not None else {})).items():
            setattr(rto, n, v)
        ee.use_raytracing, ee.use_fast_gi = rt, fg
        t0 = time.process_time()
        p = passes._render(sc)["Combined"]
        return np.stack([p[c] for c in "RGB"], -1), time.process_time() - t0

    imgs, cpus = {}, {k: [] for k in names}
    for k in names:
        imgs[k] = render(k)[0]  # untimed: the shader compilation of each pipeline
    for _ in range(a.rounds):
        for k in names:
            imgs[k], c = render(k)
            cpus[k].append(round(c, 2))
    g = passes.render_gbuffer(sc, ("albedo", "depth", "normal"), samples=1)
    geo = g["depth"][..., 0] < WORLD_DEPTH_FRACTION * sc.camera.data.clip_end
    black = geo & (g["albedo"][..., :3].max(-1) < 0.05)
    rest = geo & ~black

    def mad(x, y, m):
        return float(np.abs(x - y)[m].mean()) if m.any() else float("nan")

    res = {"blend": a.blend, "size": a.size, "samples": a.samples, "cpu_s": cpus,
           "pixels_black_albedo": int(black.sum()), "pixels_other": int(rest.sum())}
    for k in names[1:]:
        res[k] = {"black_vs_gi": mad(imgs[k], imgs["gi"], black), "other_vs_gi": mad(imgs[k], imgs["gi"], rest)}
        if "off" in imgs:
            res[k] |= {"black_vs_off": mad(imgs[k], imgs["off"], black), "other_vs_off": mad(imgs[k], imgs["off"], rest)}
    print(json.dumps(res, indent=1))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    if a.out:
        from PIL import Image
        x = np.maximum(np.concatenate([imgs[k] for k in names], 1), 0)
        Image.fromarray((np.clip((x / (1 + x)) ** (1 / 2.2), 0, 1) * 255).astype(np.uint8)).save(a.out)


if __name__ == "__main__":
    main()
