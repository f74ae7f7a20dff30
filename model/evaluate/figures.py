"""The report's figures (bpy-free, matplotlib): ``pareto.png`` (PSNR against time, one curve per family) and
``examples.png`` (one scene, every method side by side, with a 2x crop around the default model's largest
error); both written atomically."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import files, images, metrics
from .analysis import FAMILIES, closest_rung, fmt_t, ladder

PNG_EXPOSURE = 1.0


def _save_fig(fig, path) -> Path:
    """Write a matplotlib figure as PNG atomically and close it."""
    import matplotlib.pyplot as plt
    try:
        return files.atomic_write(path, lambda p: fig.savefig(p, format="png"))
    finally:
        plt.close(fig)


def _points(raw, family, which):
    pts = []
    for k, m in raw["methods"].items():
        if m["family"] == family and m.get("summary"):
            s = m["summary"]
            pts.append((s[which], s["psnr"], m))
    return sorted(pts, key=lambda p: p[0])


def pareto_png(raw: dict, path) -> Path:
    """PSNR against time (log axis), one curve per family; left: whole wall time here, right: own cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), dpi=110, sharey=True)
    titles = {"whole_s": "whole wall time per image here (2-core CPU, software GL)",
              "own_s": "own cost per image (learned: prediction only; Cycles: render + denoise)"}
    ys = [m["summary"]["psnr"] for m in raw["methods"].values() if m.get("summary") and math.isfinite(m["summary"]["psnr"])]
    for ax, which in zip(axes, ("whole_s", "own_s")):
        for fam, (label, colour, marker) in FAMILIES.items():
            pts = [p for p in _points(raw, fam, which) if math.isfinite(p[0]) and p[0] > 0 and math.isfinite(p[1])]
            if not pts:
                continue
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=colour, label=label,
                    ls="-" if len(pts) > 1 else "none", ms=7 if fam != "reference" else 12, lw=1.5)
            for t, p, m in pts:
                tag = (f"{m['spp']}" if fam.startswith("cycles") else m.get("short", ""))
                if tag:
                    ax.annotate(tag, (t, p), textcoords="offset points", xytext=(4, -10 if fam == "cycles" else 5),
                                fontsize=7, color=colour)
        front = raw.get("pareto", {}).get(which, [])
        fp = sorted((raw["methods"][k]["summary"][which], raw["methods"][k]["summary"]["psnr"]) for k in front)
        if len(fp) > 1:
            ax.step([p[0] for p in fp], [p[1] for p in fp], where="post", color="#ff7f0e", alpha=0.35, lw=6,
                    label="Pareto front", zorder=0)
        ax.set_xscale("log")
        ax.set_xlabel("seconds per image (log scale)")
        ax.set_title(titles[which], fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("PSNR, dB (seed's convention: linear, clamped to [0,1])")
    if ys:
        axes[0].set_ylim(min(ys) - 1.0, max(ys) + 1.5)
    handles, labels = axes[0].get_legend_handles_labels()
    for h_, l_ in zip(*axes[1].get_legend_handles_labels()):
        if l_ not in labels:
            handles.append(h_)
            labels.append(l_)
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=4, frameon=False)
    st = raw.get("settings", {})
    fig.suptitle(f"SSGI: error against time on {len(raw.get('scenes', []))} scene(s) at {st.get('size', '?')}", fontsize=12)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return _save_fig(fig, path)


def crop_box(h: int, w: int, err: np.ndarray | None = None) -> tuple[int, int, int, int]:
    """A half-size box (y0, y1, x0, x1): around the largest error of ``err`` (HxW) when given, else centred."""
    ch_, cw = max(1, h // 2), max(1, w // 2)
    if err is None or not np.isfinite(err).any():
        y, x = h // 2, w // 2
    else:
        from scipy.ndimage import uniform_filter
        e = uniform_filter(np.nan_to_num(err).astype(np.float64), size=(ch_, cw), mode="constant")
        y, x = np.unravel_index(int(np.argmax(e)), e.shape)
    y0 = int(min(max(0, y - ch_ // 2), h - ch_))
    x0 = int(min(max(0, x - cw // 2), w - cw))
    return y0, y0 + ch_, x0, x0 + cw


def examples_png(tiles, path, title: str = "", err: np.ndarray | None = None, cols: int = 4) -> Path:
    """``tiles``: [(title, HxWx3 linear image)], the first the reference. Each cell: the whole image with the
    crop box drawn, and below it the 2x crop (nearest). One exposure for all."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    h, w = tiles[0][1].shape[:2]
    y0, y1, x0, x1 = crop_box(h, w, err)
    rows = math.ceil(len(tiles) / cols)
    gap = max(2, h // 40)
    cw = 3.4  # inches per column
    cell_h = cw * (2 * h + gap) / w + 0.4  # image + crop, and two lines of title
    fig, axes = plt.subplots(rows, cols, figsize=(cw * cols, cell_h * rows + 0.5), dpi=110, squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for i, (name, img) in enumerate(tiles):
        im = images.srgb(img, PNG_EXPOSURE)
        crop = im[y0:y1, x0:x1].repeat(2, axis=0).repeat(2, axis=1)[:h, :w]
        cell = np.ones((2 * h + gap, w, 3))
        cell[:h] = im
        cell[h + gap:h + gap + crop.shape[0], :crop.shape[1]] = crop
        a = axes.flat[i]
        a.imshow(cell, interpolation="nearest")
        a.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False, ec="#ffcc00", lw=1))
        a.set_title(name, fontsize=7.5)
    fig.suptitle(title, fontsize=10)
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=1 - 0.75 / (cell_h * rows + 0.5), wspace=0.03,
                        hspace=0.4 / cell_h + 0.02)
    return _save_fig(fig, path)


def example_scene(raw, images):
    if not images:
        return None
    k = raw.get("default_model_key")
    ps = raw["methods"].get(k, {}).get("per_scene", {}) if k else {}
    cands = [s for s in images if s in ps]
    if not cands:
        return sorted(images)[0]
    cands.sort(key=lambda s: ps[s]["psnr"])
    return cands[len(cands) // 2]


def example_tiles(raw, imgs: dict):
    """The example cells: reference, EEVEE, the learned methods, then Cycles raw / + OIDN at the rung closest in
    time to the default model (and OIDN at 1 spp). Returns (tiles, error map of the default model)."""
    methods = raw["methods"]
    ref = imgs["ref"]
    tiles = [("Cycles reference", ref)]
    k = raw.get("default_model_key")
    oidn = ladder(methods, "cycles_oidn")
    rung = closest_rung(oidn, methods[k]["summary"]["whole_s"]) if k in methods and methods[k].get("summary") else None
    want = [kk for kk, m in methods.items() if m["family"] in ("eevee_direct", "eevee_gi", "linear", "ssgi")]
    if rung is not None:
        want += [f"cycles_{rung[0]}", f"cycles_oidn_{rung[0]}"]
    if oidn and (rung is None or rung[0] != oidn[0][0]):
        want.append(f"cycles_oidn_{oidn[0][0]}")
    for kk in want:
        if kk in imgs and kk in methods:
            m = methods[kk]
            t = m["summary"]["whole_s"] if m.get("summary") else math.nan
            psnr = metrics.psnr(imgs[kk], ref)
            tiles.append((f"{m['label']}\n{fmt_t(t)}, {psnr:.2f} dB", imgs[kk]))
    err = None
    if k in imgs:
        err = np.abs(metrics.tonemap(imgs[k]) - metrics.tonemap(ref)).mean(-1)
    return tiles, err
