"""Benchmark: does the number of EEVEE samples of the G-buffer change the shipped model's accuracy?

The dataset's G-buffer is EEVEE at 1 sample (a point sample at each pixel centre); the render path renders it
at the scene's EEVEE samples (anti-aliased). For validation rooms of the model's own split, each room is
rebuilt from its seed, its G-buffer rendered with ``passes.render_gbuffer(scene, groups, samples=S)`` for each
S, the model predicts, and the prediction is scored against the STORED reference of that sample (PSNR by the
seed's convention: linear RGB clamped to [0, 1], MSE pooled over the rooms). First, per room, an untimed
render at 1 sample (it also takes the shader compile out of the timings) is compared with the stored G-buffer
(the dataset stores half floats, so the render is rounded to half first).

    .venv/bin/python benchmarks/gbuffer_samples.py --data data/rooms3 --model models/ssgi_default.pt \\
        --rooms 8 --samples 1 4 16 --png out/gbuffer_samples.png

One JSON line per room and sample count on stdout (``"S": "stored"``: the model on the stored G-buffer), then
a ``"summary"`` line; a readable summary on stderr.
"""
import argparse
import json
import os
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: E402, F401  (the checkout as package ssgi)
import numpy as np  # noqa: E402

from ssgi.model import channels as ch  # noqa: E402
from ssgi.model.infer import predictor
from ssgi.model.dataset import exrio
from ssgi.model import metrics  # noqa: E402
from ssgi.model.images import srgb8, write_png  # noqa: E402
from ssgi.ssgi_addon.blender import passes, room
from ssgi.ssgi_addon.pipeline import report_scenes  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
ap.add_argument("--data", default="data/rooms3", help="dataset folder (its stored references are the target)")
ap.add_argument("--model", default="models/ssgi_default.pt")
ap.add_argument("--rooms", type=int, default=8, help="validation rooms to use")
ap.add_argument("--open", type=int, default=3, help="how many of them have an open side (the rest are closed)")
ap.add_argument("--samples", type=int, nargs="+", default=[1, 4, 16], help="EEVEE samples of the G-buffer")
ap.add_argument("--png", default=None, help="contact sheet: G-buffer direct at S=A | prediction at S=A | prediction at "
                                            "S=B | reference, 2x nearest (A, B: --png-samples)")
ap.add_argument("--png-samples", type=int, nargs=2, default=None, metavar=("A", "B"),
                help="the two sample counts of the PNG (default: the first and the last of --samples)")
ap.add_argument("--png-rooms", type=int, default=2, help="rooms in the PNG (the first open and the first closed)")
ap.add_argument("--boot", type=int, default=2000, help="bootstrap resamples of the rooms for the PSNR differences")
a = ap.parse_args()
if a.png_samples and not set(a.png_samples) <= set(a.samples):
    ap.error(f"--png-samples {a.png_samples} must be among --samples {a.samples}")


def log(msg):
    print(f"gbuffer_samples: {msg}", file=sys.stderr, flush=True)


pred = predictor.load_predictor(a.model)
data = Path(a.data)
scenes, over, notes = report_scenes.dataset_scenes(data, [pred.ckpt], split="val")
for n in notes:
    log(n)
size = over["size"]
# the groups the model needs, plus the Combined image ("eevee": EEVEE direct light, for the picture and a score)
groups = tuple(dict.fromkeys(pred.required + ("eevee",)))
log(f"model {a.model}: inputs {ch.format_spec(pred.spec)}, rendered groups {groups}; {len(scenes)} validation "
    f"scenes, size {size[0]}x{size[1]}")

# the first `open` open rooms and the first rooms - open closed rooms of the sorted validation scenes
is_open = {sc.name: room.room_params(int(sc.meta["seed"]))["open_side"] is not None for sc in scenes}
n_open = min(a.open, a.rooms)
chosen = [sc for sc in scenes if is_open[sc.name]][:n_open] + [sc for sc in scenes if not is_open[sc.name]][:a.rooms - n_open]
chosen.sort(key=lambda sc: sc.name)
log("rooms: " + ", ".join(sc.name + (" (open)" if is_open[sc.name] else "") for sc in chosen))


def scaled(g, k):
    """Light groups times the sample's exposure (as the dataset stored them)."""
    if k == 1.0:
        return g
    g = dict(g)
    for lg in ("direct", "world"):
        if lg in g:
            g[lg] = g[lg] * np.float32(k)
    g["eevee"] = np.concatenate([g["eevee"][..., :3] * np.float32(k), g["eevee"][..., 3:]], -1)
    return g


def agreement(rendered, stored):
    """Per group: max |rendered (rounded to half) - stored| and the fraction of values that differ."""
    out = {}
    for g in stored:
        r = np.clip(rendered[g], -65504, 65504).astype(np.float16).astype(np.float32)
        s = stored[g]
        fin = np.isfinite(r) & np.isfinite(s)
        d = np.abs(r - s)[fin]
        out[g] = dict(max_abs=float(d.max()) if d.size else 0.0, frac_diff=round(float(np.mean(r != s)), 6),
                      identical=bool(np.array_equal(r, s, equal_nan=True)))
    return out


def score(img, ref):
    p = metrics.PooledPSNR()
    p.add(img[..., :3], ref)
    return p


rows, images = [], {}
for sc in chosen:
    scene = sc.open()
    stored = exrio.read_sample(data / f"{sc.meta['key']}.exr", groups)
    ref = sc.ref
    # the model on the stored G-buffer: what the split's validation saw
    p_st = score(pred.predict(stored), ref)
    d_st = score(stored["eevee"], ref)
    row = dict(room=sc.name, open=is_open[sc.name], S="stored", psnr=round(p_st.value, 3),
               direct_psnr=round(d_st.value, 3))
    rows.append(dict(row, sse=p_st.sse, n=p_st.n, dsse=d_st.sse))
    print(json.dumps(row), flush=True)
    # untimed render at 1 sample: shaders compiled, and the check against the stored G-buffer
    g0 = scaled(passes.render_gbuffer(scene, groups, samples=1), sc.exposure)
    check = agreement(g0, stored)
    log(f"{sc.name}: S=1 vs stored: " + ", ".join(
        g + (" identical" if v["identical"] else f" max {v['max_abs']:.3g} ({100 * v['frac_diff']:.3f} % differ)")
        for g, v in check.items()))
    for s in a.samples:
        t = time.perf_counter()
        g = passes.render_gbuffer(scene, groups, samples=s)
        dt = time.perf_counter() - t
        g = scaled(g, sc.exposure)
        out = pred.predict(g)
        p, d_p = score(out, ref), score(g["eevee"], ref)
        row = dict(room=sc.name, open=is_open[sc.name], S=s, psnr=round(p.value, 3),
                   direct_psnr=round(d_p.value, 3), gbuffer_s=round(dt, 3),
                   load1=round(os.getloadavg()[0], 2))
        if s == 1:
            row["same_as_untimed_render"] = all(np.array_equal(g[k], g0[k], equal_nan=True) for k in groups)
            row["vs_stored"] = check
        rows.append(dict(row, sse=p.sse, n=p.n, dsse=d_p.sse))
        print(json.dumps(row), flush=True)
        images[(sc.name, s)] = (g["eevee"][..., :3], out)
    images[(sc.name, "ref")] = ref

# ---- summary: PSNR pooled over rooms; paired bootstrap over rooms of the difference to the first S
names = [sc.name for sc in chosen]
keys = ["stored"] + list(a.samples)
sse = {k: np.array([next(r["sse"] for r in rows if r["room"] == n and r["S"] == k) for n in names]) for k in keys}
cnt = np.array([next(r["n"] for r in rows if r["room"] == n and r["S"] == keys[0]) for n in names], dtype=float)
pooled = {k: metrics.psnr_from_mse(float(sse[k].sum() / cnt.sum())) for k in keys}
rng = np.random.default_rng(0)
idx = rng.integers(0, len(names), size=(a.boot, len(names)))


def pooled_db(e):
    return 10 * np.log10(cnt[idx].sum(1) / e[idx].sum(1))


base = a.samples[0]
summary = dict(rooms=names, open=[n for n in names if is_open[n]], samples=a.samples, model=a.model, data=str(data),
               pooled_psnr={str(k): round(v, 3) for k, v in pooled.items()},
               mean_gbuffer_s={str(s): round(float(np.mean([r["gbuffer_s"] for r in rows if r["S"] == s])), 3)
                               for s in a.samples},
               mean_gbuffer_s_closed={str(s): round(float(np.mean(
                   [r["gbuffer_s"] for r in rows if r["S"] == s and not r["open"]] or [np.nan])), 3) for s in a.samples},
               mean_gbuffer_s_open={str(s): round(float(np.mean(
                   [r["gbuffer_s"] for r in rows if r["S"] == s and r["open"]] or [np.nan])), 3) for s in a.samples},
               pooled_direct_psnr={}, delta_vs_first={})
for s in a.samples:
    d = [r for r in rows if r["S"] == s]
    # direct light alone (the Combined image), pooled the same way
    summary["pooled_direct_psnr"][str(s)] = round(metrics.psnr_from_mse(sum(r["dsse"] for r in d) / cnt.sum()), 3)
    if s != base:
        boot = pooled_db(sse[s]) - pooled_db(sse[base])
        per_room = [next(r["psnr"] for r in d if r["room"] == n) - next(r["psnr"] for r in rows if r["room"] == n
                    and r["S"] == base) for n in names]
        summary["delta_vs_first"][str(s)] = dict(
            pooled_db=round(pooled[s] - pooled[base], 3),
            bootstrap95=[round(float(np.percentile(boot, 2.5)), 3), round(float(np.percentile(boot, 97.5)), 3)],
            per_room_db=[round(x, 3) for x in per_room], rooms_better=int(sum(x > 0 for x in per_room)))
print(json.dumps(dict(summary=summary)), flush=True)
log("pooled PSNR over rooms (dB) and mean G-buffer seconds:")
log(f"  stored G-buffer: {pooled['stored']:.3f} dB")
for s in a.samples:
    dd = summary["delta_vs_first"].get(str(s))
    log(f"  S={s:3d}: {pooled[s]:.3f} dB, direct alone {summary['pooled_direct_psnr'][str(s)]:.3f} dB, "
        f"G-buffer {summary['mean_gbuffer_s'][str(s)]:.2f} s"
        + (f", {dd['pooled_db']:+.3f} dB vs S={base} (95 % {dd['bootstrap95']})" if dd else ""))

# ---- the picture: G-buffer direct at S=A | prediction at S=A | prediction at S=B | reference
if a.png:
    from PIL import Image, ImageDraw

    pick = ([n for n in names if is_open[n]][:1] + [n for n in names if not is_open[n]][:1] + names)
    pick = list(dict.fromkeys(pick))[:a.png_rooms]
    first, last = a.png_samples or (a.samples[0], a.samples[-1])
    rows_img = []
    for n in pick:
        ref = images[(n, "ref")]
        cols = [(f"EEVEE direct, S={first}", images[(n, first)][0]),
                (f"prediction, S={first}", images[(n, first)][1]),
                (f"prediction, S={last}", images[(n, last)][1]),
                ("reference (stored)", ref)]
        tiles = []
        for title, img in cols:
            im = srgb8(img).repeat(2, 0).repeat(2, 1)
            label = f"{n}{' open' if is_open[n] else ''}: {title}"
            if not title.startswith("reference"):
                label += f"  {metrics.psnr(img, ref):.2f} dB"
            pad = np.full((16, im.shape[1], 3), 255, np.uint8)
            tile = Image.fromarray(np.concatenate([pad, im], 0))
            ImageDraw.Draw(tile).text((3, 2), label, fill=(0, 0, 0))
            tiles.append(np.asarray(tile))
        gap = np.full((tiles[0].shape[0], 4, 3), 255, np.uint8)
        rows_img.append(np.concatenate(sum(([t, gap] for t in tiles), [])[:-1], 1))
    write_png(a.png, np.concatenate(rows_img, 0))
    log(f"wrote {a.png} (rooms {', '.join(pick)}; Reinhard tonemap + sRGB, 2x nearest)")
