"""Benchmark: does EEVEE's ray-tracing setup lift the ceiling of a diffuse-part model on a shot?

A diffuse-part model's image is its prediction + EEVEE's rest (model/infer/compose.py), so no diffuse prediction
can beat ``ceiling`` = Cycles' own diffuse part + EEVEE's rest against Cycles' image. This renders, for each
--frames frame of the .blend's scene camera: Cycles --spp + OIDN (``ref`` and ``ref_diffuse``, another seed per
frame), the G-buffer (the geometry mask) and EEVEE's rest (passes.render_rest at the scene's own samples) under
each variant of the ray-tracing setup, and prints the ceiling (PSNR over the geometry pixels, model/metrics) and
the mean |EEVEE rest - Cycles rest| of each, one line a frame and the mean of the frames. Variants:

    base        the scene as it is
    res1        ray tracing at full resolution (resolution_scale 1; default 1:2)
    rough1      every roughness traced (trace_max_roughness 1.0; default 0.5: rougher surfaces read probes)
    res1_rough1_q1  both, and screen-trace quality 1.0
    samples64   64 EEVEE samples
    probe       a sphere light probe (reflection cubemap) at --probe-at, 8 m influence: rough reflections read the
                room, not the world
    probe_res1_rough1  the probe, full resolution, every roughness traced

With --out, a PNG of the first frame: Cycles' rest x2 | EEVEE's rest (base) x2 | |ceiling - Cycles| x4.

    .venv/bin/python benchmarks/rest_settings.py --blend SHOT.blend --frames 6,25,43 [--spp 16] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package ssgi)

VARIANTS = {
    "base": {},
    "res1": dict(resolution_scale="1"),
    "rough1": dict(trace_max_roughness=1.0),
    "res1_rough1_q1": dict(resolution_scale="1", trace_max_roughness=1.0, screen_trace_quality=1.0),
    "samples64": dict(samples=64),
    "probe": dict(probe=True),
    "probe_res1_rough1": dict(probe=True, resolution_scale="1", trace_max_roughness=1.0),
}
TRACE_KEYS = ("resolution_scale", "trace_max_roughness", "screen_trace_quality")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blend", required=True)
    ap.add_argument("--frames", default="1", help="comma-separated frame numbers")
    ap.add_argument("--spp", type=int, default=16, help="Cycles samples of the reference (+ OIDN)")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--probe-at", default="0,0,1.3", help="x,y,z of the sphere probe (metres)")
    ap.add_argument("--out", default=None, help="folder for the PNG and rest_settings.json")
    ap.add_argument("--no-proxies", action="store_true",
                    help="EEVEE's own rest, without the area lights the render path stands in for planar emitters")
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
        probe_at = tuple(float(x) for x in a.probe_at.split(","))
        if len(probe_at) != 3:
            raise ValueError
    except ValueError:
        print(f"rest_settings: --frames {a.frames!r} / --probe-at {a.probe_at!r}: expected integers / x,y,z",
              file=sys.stderr)
        return 2
    try:
        open_blend(check_blend(a.blend))
    except UserError as e:
        print(f"rest_settings: {e}", file=sys.stderr)
        return 2
    scene = bpy.context.scene
    opts = scene.eevee.ray_tracing_options

    def set_probe(on: bool):
        ob = bpy.data.objects.get("ssgi_bench_probe")
        if on and ob is None:
            pd = bpy.data.lightprobes.new("ssgi_bench_probe", "SPHERE")
            pd.influence_distance = 8.0
            ob = bpy.data.objects.new("ssgi_bench_probe", pd)
            scene.collection.objects.link(ob)
            ob.location = probe_at
        elif not on and ob is not None:
            bpy.data.objects.remove(ob)

    out = Path(a.out) if a.out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    rows: dict[int, dict] = {}
    for f in frames:
        scene.frame_set(f)
        g = passes.render_gbuffer(scene, ("albedo", "depth", "normal"))
        mask = images.geometry_mask(g["depth"], g["normal"])
        cy = passes.render_cycles(scene, a.spp, seed=100003 + f, denoise=True, groups=("ref", "ref_diffuse"))
        ref, rd = cy["ref"][..., :3], cy["ref_diffuse"][..., :3]
        rows[f] = {}
        first = None  # (rest, ceiling) of the first variant, for the PNG
        for name in a.variants:
            v = VARIANTS[name]
            kept = {k: getattr(opts, k) for k in TRACE_KEYS}
            try:
                for k in TRACE_KEYS:
                    if k in v:
                        setattr(opts, k, v[k])
                set_probe(bool(v.get("probe")))
                t = time.perf_counter()
                rest, _ = passes.render_rest(scene, v.get("samples"),
                                             proxies=passes.REST_EMITTER_PROXIES and not a.no_proxies)
                secs = time.perf_counter() - t
            finally:
                for k, x in kept.items():
                    setattr(opts, k, x)
                set_probe(False)
            ceiling = compose(rd, {"rest": rest}, ch.DIFFUSE_TARGET)  # as the node composes a perfect prediction
            s = metrics.score(ceiling, ref, mask, with_ssim=False, with_flip=False)
            err = float(np.abs(rest - (ref - rd))[mask].mean())
            rows[f][name] = dict(ceiling_psnr=round(s["psnr"], 2), rest_abs_err=round(err, 5), rest_s=round(secs, 1))
            print(f"frame {f} {name:18s} ceiling {s['psnr']:.2f} dB  |rest err| {err:.4f}  rest render {secs:.1f} s",
                  flush=True)
            if first is None:
                first = (rest, ceiling)
        if out and f == frames[0]:
            crest = np.maximum(ref - rd, 0)
            err = np.abs(np.clip(first[1], 0, 1) - np.clip(ref, 0, 1))
            sheet = np.concatenate([crest * 2, np.maximum(first[0], 0) * 2, err * 4], axis=1)
            images.write_png(out / f"rest_settings_{f:04d}.png", images.srgb8(sheet))
    means = {n: round(float(np.mean([rows[f][n]["ceiling_psnr"] for f in frames])), 2) for n in a.variants}
    for n, m in means.items():
        print(f"mean {n:18s} ceiling {m:.2f} dB")
    if out:
        (out / "rest_settings.json").write_text(json.dumps(dict(blend=str(a.blend), frames=frames, spp=a.spp,
                                                                 proxies=not a.no_proxies, probe_at=probe_at,
                                                                 per_frame=rows, mean_ceiling=means), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
