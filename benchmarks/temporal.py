#!/usr/bin/env python3
"""Flicker of SSGI with and without its temporal mode against EEVEE's own GI and Cycles + OIDN (issue 16).

    .venv/bin/python benchmarks/temporal.py --out out/temporal [--blend SHOT.blend --frames 1-24 --scene S]
        [--size 160x90] [--ref-samples 64] [--model M.pt] [--eevee-samples 8]

Without --blend it builds the default shot (``build_shot``: 24 frames, the camera dollies and pans, a cube
crosses the room, the floor ripples with a Wave modifier). Per frame of the shot, at --size:
- SSGI through the render path (RenderSession, temporal on; the same run gives each frame's stateless
  prediction, bit-identical to the mode off: tests/blender/test_temporal.py),
- EEVEE's own GI (the artist-settings render of the same run: ray tracing and fast GI as the scene sets them),
- Cycles 1 spp + OIDN and Cycles + OIDN at equal time (the spp whose first-frame time is closest to SSGI's
  per-frame time), with Cycles' seed fixed as Blender's default (use_animated_seed off),
- the reference: Cycles --ref-samples spp + OIDN.
The table: the warped flicker (model/infer/temporal.py ``warped_change``, pixels kept by ``valid_mask`` of the
G-buffer), the unwarped change of error of the old report (analysis.temporal_change), PSNR and tonemapped PSNR
against the reference over all frames, seconds a frame. Then a sweep of the window (k, weight) re-blended from
the same stateless predictions, and OUT/strip.png (4 consecutive frames of each method) and OUT/flicker.png
(the warped change of each, x8). OUT/temporal.json has every number.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: F401,E402  (the checkout as package ssgi)


def _linear(obj):
    for lay in obj.animation_data.action.layers:
        for st in lay.strips:
            for cb in st.channelbags:
                for fc in cb.fcurves:
                    for k in fc.keyframe_points:
                        k.interpolation = "LINEAR"


def _mat(name, rgb):
    import bpy
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rgb, 1)
    bsdf.inputs["Roughness"].default_value = 1.0
    return m


def build_shot(size=(160, 90), frames: int = 24, samples: int = 8):
    """The default shot: an open-front room (floor with a Wave ripple, back and side walls), a red cube that
    crosses it, a point lamp; the camera dollies 1.4 m sideways and 0.6 m in while panning 10 degrees.
    EEVEE at ``samples`` with ray tracing and fast GI (its own GI)."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.resolution_x, sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.frame_start, sc.frame_end = 1, frames
    sc.eevee.taa_render_samples = samples
    sc.eevee.use_raytracing = True
    sc.eevee.use_fast_gi = True
    bpy.ops.mesh.primitive_plane_add(size=8)
    floor = bpy.context.object
    floor.data.materials.append(_mat("floor", (0.8, 0.7, 0.5)))
    sub = floor.modifiers.new("sub", "SUBSURF")
    sub.subdivision_type, sub.levels, sub.render_levels = "SIMPLE", 6, 6
    wave = floor.modifiers.new("wave", "WAVE")
    wave.height, wave.width, wave.speed = 0.12, 1.2, 0.15
    for name, loc, rot, rgb in (("back", (0, 3, 2), (math.radians(90), 0, 0), (0.3, 0.5, 0.8)),
                                ("left", (-3.5, 0, 2), (0, math.radians(90), 0), (0.8, 0.8, 0.8)),
                                ("right", (3.5, 0, 2), (0, math.radians(90), 0), (0.2, 0.7, 0.3))):
        bpy.ops.mesh.primitive_plane_add(size=8, location=loc, rotation=rot)
        bpy.context.object.data.materials.append(_mat(name, rgb))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-1.5, 0.5, 0.6))
    cube = bpy.context.object
    cube.data.materials.append(_mat("cube", (0.9, 0.2, 0.1)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(1.2, 1.2, 0.6))
    bpy.context.object.data.materials.append(_mat("sphere", (0.9, 0.9, 0.9)))
    li = bpy.data.lights.new("lamp", "POINT")
    li.energy, li.shadow_soft_size = 600, 0.15
    lo = bpy.data.objects.new("lamp", li)
    lo.location = (1.5, -1.0, 3.5)
    sc.collection.objects.link(lo)
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    sc.collection.objects.link(cam)
    sc.camera = cam
    cam.location, cam.rotation_euler = (-0.7, -6.5, 2.6), (math.radians(72), 0, math.radians(-5))
    cam.keyframe_insert("location", frame=1)
    cam.keyframe_insert("rotation_euler", frame=1)
    cam.location, cam.rotation_euler = (0.7, -5.9, 2.6), (math.radians(72), 0, math.radians(5))
    cam.keyframe_insert("location", frame=frames)
    cam.keyframe_insert("rotation_euler", frame=frames)
    cube.keyframe_insert("location", frame=1)
    cube.location = (1.3, -0.6, 0.6)
    cube.keyframe_insert("location", frame=frames)
    for o in (cam, cube):
        _linear(o)
    w = bpy.data.worlds.new("sky")
    w.color = (0.0, 0.0, 0.0)
    sc.world = w
    return sc


def _window_blend(parts, groups, k, w, target):
    """Re-blend the stateless parts with a window of k frames of weight w each (as the render path does)."""
    import numpy as np
    from ssgi.model import channels as ch
    from ssgi.model.infer import history as hist, temporal as tp
    from ssgi.model.infer.compose import compose
    ones = lambda g: np.ones(g["albedo"].shape[:2] + (3,), np.float32)
    la = (lambda g: g["albedo"]) if target == ch.DIFFUSE_TARGET else ones
    entries = [hist.make_entry(p, g, la(g)) for p, g in zip(parts, groups)]
    out = []
    for t, (p, g) in enumerate(zip(parts, groups)):
        e = entries[t]
        prev = [entries[j] for j in range(t - 1, max(-1, t - 1 - k), -1)]
        warped = tp.reproject_window(prev, e["vector"], {x: e[x] for x in ("depth", "normal", "albedo")}) if prev else []
        b = tp.blend(p, la(g), warped, [w] * len(warped), geometry=g["albedo"][..., :3].max(-1) > tp.EPS)
        out.append(compose(b, g, target))
    return out


def _score(imgs, refs, vectors, masks):
    import numpy as np
    from ssgi.model import metrics
    from ssgi.model.evaluate.analysis import temporal_change
    from ssgi.model.infer.temporal import warped_change
    wc = warped_change(imgs, refs, vectors, masks)
    mse = float(np.mean([np.mean((metrics.clean(i) - metrics.clean(r)) ** 2) for i, r in zip(imgs, refs)]))
    tm = float(np.mean([np.mean((metrics.tonemap(metrics.clean(i)) - metrics.tonemap(metrics.clean(r))) ** 2)
                        for i, r in zip(imgs, refs)]))
    return dict(warped=wc["change"], warped_per_step=wc["per_step"], unwarped=temporal_change(imgs, refs)["change"],
                psnr=metrics.psnr_from_mse(mse), tm_psnr=metrics.psnr_from_mse(tm))


def _figures(out: Path, seqs: dict, refs, vectors, masks, first: int, n: int = 4):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from ssgi.model import metrics
    from ssgi.model.images import srgb
    from ssgi.model.infer.temporal import reproject
    rows = {"Reference": refs} | seqs
    n = max(1, min(n, len(refs) - 1))
    first = max(1, min(first, len(refs) - n))
    exposure = 0.9 / max(float(np.percentile(np.concatenate([r.ravel() for r in refs]), 99)), 1e-6)
    for name, fn in (("strip", lambda imgs, t: srgb(imgs[t], exposure)),
                     ("flicker", None)):
        fig, axes = plt.subplots(len(rows), n, figsize=(2.2 * n, 1.45 * len(rows)), squeeze=False)
        for i, (label, imgs) in enumerate(rows.items()):
            for j in range(n):
                t = first + j
                if fn is not None:
                    im = fn(imgs, t)
                else:  # |(m_t - warp m_{t-1}) - (r_t - warp r_{t-1})| x 8, grey, masked pixels black
                    tmm = lambda a: metrics.tonemap(metrics.clean(a))
                    d = np.abs((tmm(imgs[t]) - reproject(tmm(imgs[t - 1]), vectors[t])[0])
                               - (tmm(refs[t]) - reproject(tmm(refs[t - 1]), vectors[t])[0])).mean(-1)
                    im = np.clip(8 * d * masks[t], 0, 1)
                axes[i, j].imshow(im, cmap="gray" if im.ndim == 2 else None, vmin=0, vmax=1)
                axes[i, j].set_xticks([])
                axes[i, j].set_yticks([])
                if j == 0:
                    axes[i, j].set_ylabel(label, fontsize=6)
                if i == 0:
                    axes[i, j].set_title(f"frame {t + 1}" if fn is not None else f"frame {t + 1} vs {t}", fontsize=7)
        fig.tight_layout(pad=0.2)
        from ssgi.model import files
        files.atomic_write(out / f"{name}.png", lambda p: fig.savefig(p, dpi=110, format="png"))
        plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--blend", default=None, help="a shot .blend (default: the shot built here)")
    ap.add_argument("--scene", default=None)
    ap.add_argument("--frames", default=None, help="frames A-B of --blend (default: its frame range; built: 1-24)")
    ap.add_argument("--size", default="160x90")
    ap.add_argument("--ref-samples", type=int, default=64)
    ap.add_argument("--eevee-samples", type=int, default=8, help="EEVEE samples of the built shot")
    ap.add_argument("--model", default=None)
    a = ap.parse_args()
    import bpy
    import numpy as np
    from ssgi.model.cliargs import parse_frames, parse_size
    from ssgi.model.infer import temporal as tp
    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    from ssgi.ssgi_addon.pipeline.report_run import LADDER_SEED

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    size = parse_size(a.size)
    if a.blend:
        from ssgi.ssgi_addon.blender.blendfile import open_blend, pick_scene
        open_blend(a.blend)
        sc = pick_scene(Path(a.blend), a.scene)
        passes.set_resolution(sc, *size)
    else:
        sc = build_shot(size, 24, a.eevee_samples)
    frames = list(parse_frames(a.frames)) if a.frames else list(range(sc.frame_start, sc.frame_end + 1))
    setup_scene(sc, a.model)
    log = lambda m: print(f"temporal bench: {m}", file=sys.stderr, flush=True)

    s = RenderSession(sc, frames, model=a.model, write=False, keep_groups=True, temporal="on")
    on, off, parts, groups, t_ssgi, t_eevee, eevee = [], [], [], [], [], [], []
    keep = ("albedo", "depth", "normal", "vector", "rest", "eevee")
    for info in s.iter_frames():
        on.append(info["prediction"])
        off.append(info["stateless"])
        parts.append(info["stateless_part"])
        groups.append({k: info["groups"][k] for k in keep if k in info["groups"]})
        eevee.append(info["groups"]["beauty"][..., :3])
        t_ssgi.append(info["t_total"])
        t_eevee.append(info["t_pass_renders"].get("rest", math.nan))
    target = s.target
    vectors = [g["vector"] for g in groups]
    masks = [None] + [tp.valid_mask(groups[t - 1], groups[t], vectors[t]) for t in range(1, len(frames))]
    log(f"SSGI: {np.mean(t_ssgi):.2f} s a frame")

    def cycles(spp, seed, denoise=True):
        imgs, ts = [], []
        for f in frames:
            sc.frame_set(f)
            t0 = time.perf_counter()
            imgs.append(passes.render_cycles(sc, spp, seed=seed, denoise=denoise)["ref"])
            ts.append(time.perf_counter() - t0)
        return imgs, ts

    # equal time: the spp whose first-frame time is closest to SSGI's mean per-frame time
    sc.frame_set(frames[0])
    ladder = []
    for spp in (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024):
        t0 = time.perf_counter()
        passes.render_cycles(sc, spp, seed=LADDER_SEED, denoise=True)
        ladder.append((spp, time.perf_counter() - t0))
        if ladder[-1][1] > np.mean(t_ssgi):
            break
    eq_spp = min(ladder, key=lambda st: abs(st[1] - np.mean(t_ssgi)))[0]
    log(f"equal time ladder {ladder}: {eq_spp} spp")
    c1, t_c1 = cycles(1, LADDER_SEED)
    ceq, t_ceq = cycles(eq_spp, LADDER_SEED) if eq_spp != 1 else (c1, t_c1)
    refs, t_ref = cycles(a.ref_samples, 1)
    log(f"reference {a.ref_samples} spp + OIDN: {np.mean(t_ref):.2f} s a frame")

    seqs = {"SSGI temporal on": on, "SSGI temporal off": off, "EEVEE GI": eevee,
            "Cycles 1 spp + OIDN": c1, f"Cycles {eq_spp} spp + OIDN (equal time)": ceq}
    times = {"SSGI temporal on": float(np.mean(t_ssgi)), "SSGI temporal off": float(np.mean(t_ssgi)),
             "EEVEE GI": float(np.nanmean(t_eevee)), "Cycles 1 spp + OIDN": float(np.mean(t_c1)),
             f"Cycles {eq_spp} spp + OIDN (equal time)": float(np.mean(t_ceq))}
    res = {k: _score(v, refs, vectors, masks) | {"s_per_frame": times[k]} for k, v in seqs.items()}
    sweep = []
    for k in (1, 2, 3, 4):
        for w in (0.3, 0.6, 1.0, 2.0):
            sc_ = _score(_window_blend(parts, groups, k, w, target), refs, vectors, masks)
            sweep.append(dict(k=k, weight=w, warped=sc_["warped"], psnr=sc_["psnr"], tm_psnr=sc_["tm_psnr"]))
    _figures(out, seqs, refs, vectors, masks, first=len(frames) // 2)
    mask_share = float(np.mean([m.mean() for m in masks[1:]]))
    summary = dict(blend=a.blend or "built: benchmarks/temporal.py build_shot", frames=[frames[0], frames[-1]],
                   size=list(size), ref_samples=a.ref_samples, equal_time_spp=eq_spp, ladder=ladder,
                   window=tp.WINDOW, weight=tp.HISTORY_WEIGHT, scored_pixel_share=mask_share, methods=res,
                   sweep=sweep, bar=dict(
                       flicker=res["SSGI temporal on"]["warped"] <= res["Cycles 1 spp + OIDN"]["warped"],
                       psnr_cost_db=res["SSGI temporal off"]["psnr"] - res["SSGI temporal on"]["psnr"]))
    from ssgi.model import files
    files.write_json(out / "temporal.json", summary)
    print(f"{len(frames)} frames at {size[0]}x{size[1]}, reference Cycles {a.ref_samples} spp + OIDN; warped flicker "
          f"over {100 * mask_share:.0f} % of the pixels")
    print(f"| method | warped flicker | unwarped change | PSNR dB | tm PSNR dB | s/frame |\n|---|---|---|---|---|---|")
    for k, r in res.items():
        print(f"| {k} | {r['warped']:.4f} | {r['unwarped']:.4f} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} | "
              f"{r['s_per_frame']:.2f} |")
    print("\n| k | weight | warped flicker | PSNR dB | tm PSNR dB |\n|---|---|---|---|---|")
    for r in sweep:
        print(f"| {r['k']} | {r['weight']} | {r['warped']:.4f} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} |")
    print(json.dumps(summary["bar"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
