#!/usr/bin/env python3
"""Flicker of SSGI with and without its temporal mode against EEVEE's own GI and Cycles + OIDN.

    .venv/bin/python benchmarks/temporal.py --out out/temporal [--blend SHOT.blend --frames 1-24 --scene S]
        [--size 160x90] [--ref-samples 64] [--model M.pt] [--eevee-samples 8]

Without --blend it builds the default shot (ssgi_addon/blender/temporal_shot.py ``build_shot``: 24 frames, the camera dollies and pans, a cube
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
import sys
from pathlib import Path

import _bootstrap  # noqa: F401,E402  (the checkout as package ssgi)


def _window_blend(parts, groups, k, w, target, clamp=True):
    """Re-blend the stateless parts with a window of k frames of weight w each (as the render path does)."""
    import numpy as np
    from ssgi.model import channels as ch
    from ssgi.model.infer import history as hist, temporal as tp
    from ssgi.model.infer.compose import compose
    ones = lambda g: np.ones(g["albedo"].shape[:2] + (3,), np.float32)
    la = (lambda g: g["albedo"]) if ch.adds_rest(target) else ones
    entries = [hist.make_entry(p, g, la(g)) for p, g in zip(parts, groups)]
    out = []
    for t, (p, g) in enumerate(zip(parts, groups)):
        e = entries[t]
        prev = [entries[j] for j in range(t - 1, max(-1, t - 1 - k), -1)]
        warped = tp.reproject_window(prev, e["vector"], {x: e[x] for x in ("depth", "normal", "albedo", "direct_light")
                                                             if x in e}) if prev else []
        b = tp.blend(p, la(g), warped, [w] * len(warped), geometry=g["albedo"][..., :3].max(-1) > tp.EPS,
                     clamp=clamp)
        out.append(compose(b, g, target))
    return out


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
    ap.add_argument("--no-equal-time", action="store_true", help="skip Cycles at equal time (the longest part)")
    a = ap.parse_args()
    import numpy as np
    from ssgi.model.cliargs import parse_frames, parse_size
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    from ssgi.ssgi_addon.pipeline import shot_measure

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    size = parse_size(a.size)
    if a.blend:
        sc = shot_measure.open_shot(a.blend, size, a.scene, a.model)
    else:
        from ssgi.ssgi_addon.blender.temporal_shot import build_shot
        sc = build_shot(size, 24, a.eevee_samples)
        setup_scene(sc, a.model)
    frames = list(parse_frames(a.frames)) if a.frames else list(range(sc.frame_start, sc.frame_end + 1))
    log = lambda m: print(f"temporal bench: {m}", file=sys.stderr, flush=True)

    r = shot_measure.measure(sc, frames, model=a.model, ref_samples=a.ref_samples, log=log, keep_images=True,
                             equal_time=not a.no_equal_time)
    res, seqs, refs, vectors, masks = r["methods"], r["images"], r["refs"], r["vectors"], r["masks"]
    parts, groups, target = r["parts"], r["groups"], r["target"]
    sweep = []
    for clamp in (False, True):
        for k in (1, 2, 3, 4):
            for w in (0.3, 0.6, 1.0, 2.0):
                sc_ = shot_measure.score(_window_blend(parts, groups, k, w, target, clamp), refs, vectors, masks)
                sweep.append(dict(clamp=clamp, k=k, weight=w, warped=sc_["warped"], psnr=sc_["psnr"],
                                  tm_psnr=sc_["tm_psnr"]))
    np.savez(out / "frames.npz", **{f"part_{i}": p for i, p in enumerate(parts)},
             **{f"ref_{i}": x for i, x in enumerate(refs)},
             **{f"{g}_{i}": v for i, gr in enumerate(groups) for g, v in gr.items()})
    _figures(out, seqs, refs, vectors, masks, first=len(frames) // 2)
    mask_share = r["scored_pixel_share"]
    summary = {k: v for k, v in r.items() if k not in ("images", "refs", "vectors", "masks", "parts", "groups")}
    summary.update(blend=a.blend or "built: ssgi_addon/blender/temporal_shot.py build_shot", sweep=sweep)
    from ssgi.model import files
    files.write_json(out / "temporal.json", summary)
    print(f"{len(frames)} frames at {size[0]}x{size[1]} (equal time: {r['equal_time_spp']} spp), reference Cycles {a.ref_samples} spp + OIDN; warped flicker "
          f"over {100 * mask_share:.0f} % of the pixels")
    print(f"| method | warped flicker | unwarped change | PSNR dB | tm PSNR dB | s/frame |\n|---|---|---|---|---|---|")
    for k, r in res.items():
        print(f"| {k} | {r['warped']:.4f} | {r['unwarped']:.4f} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} | "
              f"{r['s_per_frame']:.2f} |")
    print("\n| clamp | k | weight | warped flicker | PSNR dB | tm PSNR dB |\n|---|---|---|---|---|---|")
    for r in sweep:
        print(f"| {r['clamp']} | {r['k']} | {r['weight']} | {r['warped']:.4f} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} |")
    print(json.dumps(summary["bar"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
