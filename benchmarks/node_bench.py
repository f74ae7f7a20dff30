#!/usr/bin/env python3
"""Benchmark and look at the SSGI render path on a random room with a camera move (see docs/node.md).

    .venv/bin/python benchmarks/node_bench.py --seed 3 --size 240x135 --frames 3 --model M.pt --out out/node_bench \
        [--cycles-samples 64] [--png]

Builds room SEED (ssgi_addon/room.py), animates the camera over FRAMES frames, runs Set up SSGI, saves
OUT/room.blend, renders every frame through the SSGI path (RenderSession, the code behind `cli.py render`)
and prints a JSON summary with per-frame timings and peak memory. With --png, also renders the Cycles
reference of each frame and writes OUT/compare_NNNN.png: EEVEE direct-only | SSGI | Cycles (one exposure: the
reference's 99th percentile -> 0.9; sRGB, clipped).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)


def srgb(x):
    import numpy as np
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--size", default="240x135")
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--model", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--cycles-samples", type=int, default=64)
    ap.add_argument("--png", action="store_true")
    a = ap.parse_args()

    from ssgi.model.dataset.exrio import stdout_to_stderr
    with stdout_to_stderr():  # stdout: JSON only
        summary = bench(a)
    print(json.dumps(summary, indent=1, default=str))
    return 0


def bench(a) -> dict:
    import bpy
    import numpy as np
    from ssgi.ssgi_addon.blender import compositor, passes, scene_state
    from ssgi.ssgi_addon.pipeline import render

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    w, h = (int(v) for v in a.size.lower().split("x"))
    ((_, scene),) = _bootstrap.rooms([a.seed], (w, h))
    scene.eevee.taa_render_samples = 1
    cam = scene.camera
    # a camera move: a slow pan (yaw) and a small dolly sideways along the camera's own x axis
    x_axis = cam.matrix_world.to_3x3().col[0]
    loc0, rot0 = cam.location.copy(), cam.rotation_euler.copy()
    scene.frame_start, scene.frame_end = 1, a.frames
    for i, f in enumerate(range(1, a.frames + 1)):
        t = i / max(1, a.frames - 1) - 0.5
        cam.location = loc0 + x_axis * (0.4 * t)
        cam.rotation_euler = (rot0.x, rot0.y, rot0.z + math.radians(8) * t)
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
    scene.frame_set(1)
    ims = scene.render.image_settings
    ims.file_format = "PNG"
    scene.render.filepath = str(out / "ssgi_####")
    compositor.setup_scene(scene, a.model)
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "room.blend"))

    t0 = time.perf_counter()
    session = render.RenderSession(scene, list(range(1, a.frames + 1)), keep_groups=a.png)
    summary = session.run()
    summary["wall_s"] = time.perf_counter() - t0
    summary["size"] = [w, h]
    summary["params"] = int(session.predictor.ckpt.get("params", 0))
    summary["variant"] = session.predictor.arch.get("variant")

    if a.png:
        from skimage.io import imsave
        for info in session.results:
            scene.frame_set(info["frame"])
            with scene_state.preserved(scene):
                t = time.perf_counter()
                ref = passes.render_cycles(scene, a.cycles_samples, seed=0, denoise=True)["ref"]
                info["t_cycles"] = time.perf_counter() - t
            ee = info["groups"]["eevee"][..., :3]
            k = 0.9 / max(1e-6, float(np.percentile(ref.mean(-1), 99)))  # one exposure for all three
            row = np.concatenate([srgb(k * ee), srgb(k * info["prediction"]), srgb(k * ref)], axis=1)
            path = out / f"compare_{info['frame']:04d}.png"
            imsave(path, (row * 255 + 0.5).astype(np.uint8), check_contrast=False)
            info["compare_png"] = str(path)
            err = lambda x: float(np.mean(np.abs(x - ref)))  # noqa: E731
            info["mae_vs_cycles"] = {"eevee_direct": err(ee), "ssgi": err(info["prediction"])}
        summary["per_frame"] = [{k: v for k, v in r.items() if k not in ("groups", "prediction")}
                                for r in session.results]
    return summary


if __name__ == "__main__":
    sys.exit(main())
