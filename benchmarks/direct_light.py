"""Benchmark: direct light inputs beyond the hard-shadow G-buffer (docs/direct_light.md).

``soft``: EEVEE's Diffuse Direct with the lights at their real size (ssgi_addon/blender/direct_light.py
render_soft_direct) at several TAA samples / shadow jitter / shadow ray and step counts, and the hard-shadow
G-buffer, against Cycles' converged Diffuse Direct (real light sizes, black world, point-sampled pixels, no
bounces), PSNR (model/metrics.py) and seconds per render, one JSON line per room and setting.

``emit``: ways to give the network the light that emissive meshes cast, on the emission-lit test room
(room_scenes.emission_room) and on lamp-lit rooms: Cycles' Diffuse Direct at a few spp raw and OIDN-denoised,
EEVEE with screen-space ray tracing on (world black), EEVEE's hard direct, and the emission pass alone.

    .venv/bin/python benchmarks/direct_light.py soft --rooms 0 1 2 3 4 5 --out out/direct_light/soft
    .venv/bin/python benchmarks/direct_light.py emit --rooms 0 2 --out out/direct_light/emit

``--out`` receives results.jsonl and, per room, an .npz of every image (for the figures: --png ROOM).
"""
import argparse
import json
import time
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402

from ssgi.model import images, metrics  # noqa: E402
from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import direct_light as dl, passes, room  # noqa: E402

# (label, render_soft_direct keyword arguments)
SOFT_SETTINGS = [(f"s{s}_{'jit' if j else 'nojit'}", dict(samples=s, jitter=j)) for s in (1, 4, 16) for j in (False, True)]
SOFT_SETTINGS += [(f"s{s}_{'jit' if j else 'nojit'}_r{r}_st{st}", dict(samples=s, jitter=j, ray_count=r, step_count=st))
                  for s, j, r, st in ((1, False, 4, 12), (4, False, 4, 12), (1, False, 4, 16), (2, False, 4, 12),
                                      (4, True, 4, 12))]  # EEVEE's ray count stops at 4 (RNA hard max)

ap = argparse.ArgumentParser()
ap.add_argument("what", choices=("soft", "emit", "table", "png", "timing"),
                help="table: markdown tables of --out's results.jsonl; png: side-by-side of --png-keys of room --png")
ap.add_argument("--rooms", type=int, nargs="+", default=[0, 1, 2, 3, 4, 5])
ap.add_argument("--size", type=parse_size, default=(240, 135))
ap.add_argument("--ref-spp", type=int, default=1024, help="Cycles samples of the reference (default 1024)")
ap.add_argument("--settings", nargs="*", help="soft: only these labels (and 'hard')")
ap.add_argument("--repeat", type=int, default=3, help="timing: renders per setting, interleaved (median)")
ap.add_argument("--tilt", type=float, default=0.0, help="emission rooms: camera pitched up by this (radians)")
ap.add_argument("--mixed", action="store_true", help="emission rooms keep their lamps too")
ap.add_argument("--reuse", action="store_true", help="soft: take the Cycles reference (and images) from --out's npz")
ap.add_argument("--png", help="png: the room (its soft_/emit_ npz in --out: 1, -2, -2_tilt)")
ap.add_argument("--png-keys", default="hard,s4_nojit_r4_st12,cycles", help="png: images left to right")
ap.add_argument("--png-kind", default="soft", choices=("soft", "emit"))
ap.add_argument("--png-name", type=Path, help="png: the file to write")
ap.add_argument("--png-crop", help="png: y0,y1,x0,x1 of each image, shown 3x")
ap.add_argument("--out", type=Path, required=True)
a = ap.parse_args()
a.out.mkdir(parents=True, exist_ok=True)
log = (a.out / "results.jsonl").open("a")


def timed(fn, *args, **kw):
    t = time.perf_counter()
    img = fn(*args, **kw)
    return img, round(time.perf_counter() - t, 2)


def emit(row):
    print(json.dumps(row), flush=True)
    log.write(json.dumps(row) + "\n")
    log.flush()


def lit_psnr(img, ref):
    """PSNR over the whole frame (metrics.psnr, clamped linear) and over its lit pixels (ref > 1e-3)."""
    m = ref.max(-1) > 1e-3
    return round(metrics.psnr(img, ref), 2), round(metrics.psnr(img[m], ref[m]), 2)


def scenes():
    scene = _bootstrap.empty_scene()
    for r in a.rooms:
        if r < 0:  # -SEED: closed room SEED lit only by an emissive ceiling panel
            dl.emission_panel_room(-r, scene, camera_tilt=a.tilt, keep_lamps=a.mixed)
        else:
            room.build_room(r, scene)
        passes.set_resolution(scene, *a.size)
        yield r, scene


def soft():
    settings = [s for s in SOFT_SETTINGS if not a.settings or s[0] in a.settings]
    for r, scene in scenes():
        npz = a.out / f"soft_{r}.npz"
        if a.reuse and npz.exists():
            imgs = dict(np.load(npz))
            ref = imgs["cycles"]
        else:
            ref, t_ref = timed(dl.render_cycles_direct, scene, a.ref_spp, seed=1)
            ref2, _ = timed(dl.render_cycles_direct, scene, a.ref_spp, seed=2)
            imgs = {"cycles": ref}
            emit(dict(room=r, setting="cycles_seed2", s=t_ref, psnr=lit_psnr(ref2, ref)))
        if not a.settings or "hard" in a.settings:
            hard, t = timed(lambda: passes.render_gbuffer(scene, ("direct",), keep_sky=False)["direct"][..., :3])
            imgs["hard"] = hard
            emit(dict(room=r, setting="hard", s=t, psnr=lit_psnr(hard, ref), ratio=round(float(hard.sum() / ref.sum()), 4)))
        for label, kw in settings:
            img, t = timed(dl.render_soft_direct, scene, **kw)
            imgs[label] = img
            emit(dict(room=r, setting=label, s=t, psnr=lit_psnr(img, ref), ratio=round(float(img.sum() / ref.sum()), 4)))
        np.savez_compressed(npz, **imgs)


def side_by_side(path, tiles, exposure=1.0, crop=None):
    if crop:
        y0, y1, x0, x1 = map(int, crop.split(","))
        tiles = [np.repeat(np.repeat(t[y0:y1, x0:x1], 3, 0), 3, 1) for t in tiles]
    row = np.concatenate([images.srgb8(t, exposure) for t in tiles], axis=1)
    images.write_png(path, row)


def eevee_raytraced(scene, samples):
    """(b): EEVEE's Diffuse Direct with screen-space ray tracing and fast GI on, real light sizes, world black."""
    passes.configure_gbuffer(scene, ("direct",), samples=samples)
    ee = scene.eevee
    ee.use_raytracing, ee.ray_tracing_method, ee.use_fast_gi = True, "SCREEN", True
    with passes._direct_only_world(scene):
        out = passes._render(scene)
    ee.use_raytracing = ee.use_fast_gi = False
    return passes._group(out, "direct")[..., :3]


def emission_pass(scene):
    """(c): EEVEE's Emission pass (the emitters as seen, lighting nothing)."""
    passes.configure_gbuffer(scene, ("direct",), samples=1)
    scene.view_layers[0].use_pass_emit = True
    with passes._direct_only_world(scene):
        out = passes._render(scene)
    return np.stack([out["Emission"][c] for c in "RGB"], axis=-1)


def emit_bench():
    for r, scene in scenes():
        ref, t_ref = timed(dl.render_cycles_direct, scene, a.ref_spp, seed=1)
        ref2, _ = timed(dl.render_cycles_direct, scene, a.ref_spp, seed=2)
        imgs = {"cycles": ref}
        if r < 0 and (a.tilt or a.mixed):
            r = f"{r}{'_tilt' if a.tilt else ''}{'_mixed' if a.mixed else ''}"
        emit(dict(room=r, setting="cycles_seed2", s=t_ref, psnr=lit_psnr(ref2, ref), mean=round(float(ref.mean()), 4)))
        runs = [("eevee_hard", lambda: passes.render_gbuffer(scene, ("direct",), keep_sky=False)["direct"][..., :3]),
                ("eevee_soft", lambda: dl.render_soft_direct(scene))]
        for spp in (1, 2, 4):
            runs.append((f"cycles_{spp}spp_raw", lambda spp=spp: dl.render_emitter_direct(scene, spp, 3, False, lamps=True)))
            runs.append((f"cycles_{spp}spp_oidn", lambda spp=spp: dl.render_emitter_direct(scene, spp, 3, lamps=True)))
        for spp in (1, 4):  # EEVEE's soft lamps + Cycles' denoised emitters (lamps hidden)
            runs.append((f"eevee_soft+emitters_{spp}spp_oidn", lambda spp=spp: dl.render_soft_direct(scene)
                         + dl.render_emitter_direct(scene, spp, seed=3)))
        runs += [("eevee_raytraced_s1", lambda: eevee_raytraced(scene, 1)),
                 ("eevee_raytraced_s4", lambda: eevee_raytraced(scene, 4)),
                 ("emission_pass", lambda: emission_pass(scene))]
        for label, fn in runs:
            img, t = timed(fn)
            imgs[label] = img
            emit(dict(room=r, setting=label, s=t, psnr=lit_psnr(img, ref),
                      ratio=round(float(img.sum() / max(ref.sum(), 1e-9)), 4)))
        np.savez_compressed(a.out / f"emit_{r}.npz", **imgs)


def table():
    rows = [json.loads(line) for line in (a.out / "results.jsonl").open()]
    rooms = sorted({r["room"] for r in rows}, key=str)
    labels = list(dict.fromkeys(r["setting"] for r in rows))
    last = {(r["room"], r["setting"]): r for r in rows}  # a rerun of a setting replaces the earlier line
    print("| setting | " + " | ".join(f"room {r}" for r in rooms) + " | pooled PSNR | pooled lit-pixel PSNR | median s |")
    print("|---" * (len(rooms) + 4) + "|")
    for lab in labels:
        got = [last.get((r, lab)) for r in rooms]
        have = [g for g in got if g]
        cells = [f"{g['psnr'][0]:.1f}" if g else "-" for g in got]
        # pooled over the rooms (the seed's convention): the mean of the rooms' MSEs (same pixel count each;
        # the lit-pixel one weighs the rooms alike)
        mean = metrics.psnr_from_mse(np.mean([10 ** (-g["psnr"][0] / 10) for g in have]))
        mean_lit = metrics.psnr_from_mse(np.mean([10 ** (-g["psnr"][1] / 10) for g in have]))
        print(f"| {lab} | " + " | ".join(cells) + f" | {mean:.2f} | {mean_lit:.2f} | {np.median([g['s'] for g in have]):.1f} |")


def timing():
    """Seconds per render of ``--settings`` (and 'hard'), interleaved ``--repeat`` times in one warm process,
    after one untimed warm-up render: the median of each."""
    settings = dict(s for s in SOFT_SETTINGS if not a.settings or s[0] in a.settings)
    runs = {"hard": lambda sc: passes.render_gbuffer(sc, ("direct",), keep_sky=False)}
    runs.update({lab: (lambda sc, kw=kw: dl.render_soft_direct(sc, **kw)) for lab, kw in settings.items()})
    for r, scene in scenes():
        runs["hard"](scene)
        times = {lab: [] for lab in runs}
        for _ in range(a.repeat):
            for lab, fn in runs.items():
                times[lab].append(timed(fn, scene)[1])
        for lab, ts in times.items():
            emit(dict(room=r, setting=lab, timing=ts, median_s=float(np.median(ts))))


if a.what == "timing":
    timing()
elif a.what == "soft":
    soft()
elif a.what == "emit":
    emit_bench()
elif a.what == "table":
    table()
else:
    d = np.load(a.out / f"{a.png_kind}_{a.png}.npz")
    side_by_side(a.png_name or a.out / f"{a.png_kind}_{a.png}.png", [d[k] for k in a.png_keys.split(",")], crop=a.png_crop)
