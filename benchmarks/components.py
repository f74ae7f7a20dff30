"""Benchmark: what each image component costs EEVEE against Cycles, on the artist test set.

For each artist scene (scenes/artist.py) it renders
- Cycles at --spp + OIDN: the whole image ``ref`` and its diffuse part ``ref_diffuse`` (Diffuse Color x
  (Diffuse Direct + Indirect), denoised by the compositor's OIDN node); Cycles' rest = ref - ref_diffuse;
- EEVEE's own render at the scene's settings (ray tracing and fast GI on) at --eevee-samples
  (passes.render_rest): its Combined image, its rest and its diffuse part = Combined - rest;
- EEVEE's direct-only G-buffer (passes.render_gbuffer: albedo, direct, depth, normal at 1 sample, hard lights,
  a world that lights nothing): albedo x direct, the diffuse image of a network that adds nothing;
and scores (model/metrics.score, PSNR / SSIM / FLIP over the geometry pixels, as the report does):
1. ``eevee``: EEVEE's whole image vs Cycles' (EEVEE's own GI, the baseline SSGI must beat);
2. ``diffuse``: EEVEE's diffuse part vs Cycles'; ``rest``: EEVEE's rest vs Cycles' rest;
3. ``ceiling``: Cycles' diffuse part + EEVEE's rest vs Cycles' image (a perfect diffuse prediction);
   ``no_network``: albedo x direct (G-buffer) + EEVEE's rest vs Cycles' image;
4. the mean of each component and its share of the image.
One PNG per scene in --out (images.srgb8): top row Cycles | EEVEE own | ceiling, bottom row Cycles' rest |
EEVEE's rest | no_network; components.json beside them; a markdown table on stderr.

    nice -n 10 .venv/bin/python benchmarks/components.py --out out/components [--names studio ...] \\
        [--size 320x180] [--eevee-samples 16] [--spp 128]
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
from scenes import artist as A  # noqa: E402  (benchmarks/ is on sys.path: the script's own folder)
import numpy as np  # noqa: E402

from ssgi.model import images, metrics  # noqa: E402
from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import passes  # noqa: E402

# what is scored against what: name -> (prediction key, reference key) of the images of ``components``
SCORED = {"eevee": ("eevee_image", "cycles_image"), "diffuse": ("eevee_diffuse", "cycles_diffuse"),
          "rest": ("eevee_rest", "cycles_rest"), "ceiling": ("ceiling", "cycles_image"),
          "no_network": ("no_network", "cycles_image")}
MEANS = ("cycles_image", "cycles_diffuse", "cycles_rest", "eevee_image", "eevee_diffuse", "eevee_rest",
         "gbuffer_diffuse")


def render_components(scene, eevee_samples: int, spp: int, seed: int = 1) -> tuple[dict, np.ndarray, dict]:
    """The images of one scene ({key: HxWx3 linear}), its geometry mask and the seconds of each render."""
    t = time.perf_counter()
    g = passes.render_gbuffer(scene, ("albedo", "direct", "depth", "normal"))
    t_g = time.perf_counter() - t
    t = time.perf_counter()
    ee_rest, ee_comb = passes.render_rest(scene, eevee_samples)
    t_e = time.perf_counter() - t
    t = time.perf_counter()  # last: render_cycles leaves its settings on the scene
    cy = passes.render_cycles(scene, spp, seed=seed, denoise=True, groups=("ref", "ref_diffuse"))
    t_c = time.perf_counter() - t
    ee_img = ee_comb[..., :3]
    im = dict(cycles_image=cy["ref"], cycles_diffuse=cy["ref_diffuse"], cycles_rest=cy["ref"] - cy["ref_diffuse"],
              eevee_image=ee_img, eevee_diffuse=ee_img - ee_rest, eevee_rest=ee_rest,
              gbuffer_diffuse=g["albedo"][..., :3] * g["direct"][..., :3])
    im["ceiling"] = im["cycles_diffuse"] + ee_rest
    im["no_network"] = im["gbuffer_diffuse"] + ee_rest
    mask = images.geometry_mask(g["depth"], g["normal"])
    return im, mask, dict(gbuffer_s=round(t_g, 1), eevee_s=round(t_e, 1), cycles_s=round(t_c, 1))


def _num(x, nd=4):
    return None if x is None or not math.isfinite(x) else round(float(x), nd)


NEGATIVE = -0.01  # a rest pixel below this (any channel) counts as negative


def _worst_share(pred, ref, mask, top: float = 0.02) -> float:
    """The share of the squared error (clamped [0, 1], over ``mask``) that lies in the worst ``top`` of the pixels:
    near 1 when a few pixels (one object) make the error."""
    e = np.sum((np.clip(pred, 0, 1) - np.clip(ref, 0, 1)) ** 2, axis=-1)[mask]
    e = np.sort(e)[::-1]
    return float(e[:max(1, int(top * e.size))].sum() / e.sum()) if e.size and e.sum() > 0 else math.nan


def measure(im: dict, mask: np.ndarray) -> dict:
    """Scores (SCORED, over ``mask``) and means (over the whole frame) of one scene's images."""
    out = {}
    for name, (p, r) in SCORED.items():
        s = metrics.score(im[p], im[r], mask)
        out[name] = dict(psnr=_num(s["psnr"], 2), ssim=_num(s["ssim"]), flip=_num(s["flip"]),
                         psnr_frame=_num(metrics.psnr(im[p], im[r]), 2))
    out["mean"] = {k: _num(float(im[k].mean())) for k in MEANS}
    out["mean_geometry"] = {k: _num(float(im[k][mask].mean())) if mask.any() else None for k in MEANS}
    out["negative_mean"] = {k: _num(float(np.minimum(im[k], 0).mean()), 5) for k in ("cycles_rest", "eevee_rest")}
    out["negative_fraction"] = {k: _num(float((im[k].min(axis=-1) < NEGATIVE).mean()), 4)
                                for k in ("cycles_rest", "eevee_rest")}
    out["ceiling_error_in_worst_2pc"] = _num(_worst_share(im["ceiling"], im["cycles_image"], mask), 3)
    out["geometry_fraction"] = _num(float(mask.mean()), 3)
    return out


def sheet(im: dict) -> np.ndarray:
    """uint8 sRGB: Cycles | EEVEE own | ceiling over Cycles' rest | EEVEE's rest | no_network (4 px white gaps)."""
    h, w = im["cycles_image"].shape[:2]
    vgap, hgap = np.ones((h, 4, 3), np.float32), np.ones((4, 3 * w + 8, 3), np.float32)
    rows = [np.concatenate([im[a], vgap, im[b], vgap, im[c]], axis=1)
            for a, b, c in (("cycles_image", "eevee_image", "ceiling"), ("cycles_rest", "eevee_rest", "no_network"))]
    srgb = images.srgb8(np.concatenate([rows[0], hgap, rows[1]], axis=0))
    gaps = np.zeros(srgb.shape[:2], bool)
    gaps[h:h + 4, :] = True
    gaps[:, w:w + 4] = gaps[:, 2 * w + 4:2 * w + 8] = True
    srgb[gaps] = 255  # the gaps white (Reinhard maps 1.0 to grey)
    return srgb


def table(rows: list[dict]) -> str:
    """Markdown: per scene PSNR / SSIM / FLIP of each scored pair, then the component means and shares."""
    head = "| scene | " + " | ".join(f"{k} PSNR / SSIM / FLIP" for k in SCORED) + " |"
    lines = [head, "|---" * (len(SCORED) + 1) + "|"]
    for r in rows:
        cells = [f"{r[k]['psnr']:.2f} / {r[k]['ssim']:.3f} / {r[k]['flip']:.3f}" for k in SCORED]
        lines.append(f"| {r['scene']} | " + " | ".join(cells) + " |")
    mean_row = [f"{np.mean([r[k]['psnr'] for r in rows]):.2f} / {np.mean([r[k]['ssim'] for r in rows]):.3f} / "
                f"{np.mean([r[k]['flip'] for r in rows]):.3f}" for k in SCORED]
    lines.append("| mean | " + " | ".join(mean_row) + " |")
    lines += ["", "| scene | Cycles image | Cycles diffuse | Cycles rest | EEVEE image | EEVEE diffuse | EEVEE rest | "
                  "G-buffer diffuse | rest share Cycles / EEVEE (frame) | (geometry) | s G-buffer / EEVEE / Cycles |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        m, g, t = r["mean"], r["mean_geometry"], r["seconds"]

        def shares(d):
            return " / ".join(f"{d[f'{k}_rest'] / d[f'{k}_image']:.0%}" if d[f"{k}_image"] else "-"
                              for k in ("cycles", "eevee"))
        lines.append(f"| {r['scene']} | " + " | ".join(f"{m[k]:.4f}" for k in MEANS) +
                     f" | {shares(m)} | {shares(g)} | {t['gbuffer_s']} / {t['eevee_s']} / {t['cycles_s']} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="What each image component (diffuse part, rest) costs EEVEE against "
                                             "Cycles on the artist test set, and the ceiling of prediction + rest.")
    ap.add_argument("--names", nargs="+", choices=A.NAMES, default=list(A.NAMES), help="scenes (default: all)")
    ap.add_argument("--size", type=parse_size, default=(320, 180), help="render size (320x180)")
    ap.add_argument("--eevee-samples", type=int, default=16, help="EEVEE's own render samples (16)")
    ap.add_argument("--spp", type=int, default=128, help="Cycles samples, + OIDN (128)")
    ap.add_argument("--out", required=True, help="folder for <scene>.png and components.json")
    ap.add_argument("--npz", help="also save each scene's images and mask as NPZ/<scene>.npz (for a closer look)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in a.names:
        scene = A.build(name, tuple(a.size))
        im, mask, secs = render_components(scene, a.eevee_samples, a.spp)
        images.write_png(out / f"{name}.png", sheet(im))
        if a.npz:
            Path(a.npz).mkdir(parents=True, exist_ok=True)
            np.savez_compressed(Path(a.npz) / f"{name}.npz", mask=mask, **im)
        row = dict(scene=name, **measure(im, mask), seconds=secs)
        rows.append(row)
        print(json.dumps(row), flush=True)
    settings = dict(size="%dx%d" % tuple(a.size), eevee_samples=a.eevee_samples, spp=a.spp, oidn=True, mask="geometry")
    (out / "components.json").write_text(json.dumps(dict(settings=settings, scenes=rows), indent=1) + "\n")
    print(table(rows), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
