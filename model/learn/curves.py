"""Learning curves (matplotlib, bpy-free): one training's validation PSNR (``MODEL.curve.png``, written by the
Trainer after every run) and several checkpoints' curves in one plot (``cli.py curves``)."""
from __future__ import annotations

from pathlib import Path

from .. import files
from . import checkpoint


def curve_png(history, path, title="") -> None:
    """Validation PSNR (seed's convention) against training minutes."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = [h["minutes"] for h in history]
    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    ax.plot(xs, [h["val_psnr"] for h in history], "o-", ms=3, label="val PSNR (linear, clamped)")
    ax.plot(xs, [h["val_tm_psnr"] for h in history], "s--", ms=3, alpha=0.6, label="val PSNR (tonemapped)")
    _finish_plot(fig, ax, path, title, "PSNR (dB)")


def _finish_plot(fig, ax, path, title, ylabel, fontsize=None, xlabel="training minutes") -> None:
    """Label, then save atomically (temp name + rename)."""
    import matplotlib.pyplot as plt

    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=fontsize)
    fig.tight_layout()
    try:
        files.atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))
    finally:
        plt.close(fig)


def compare_png(models, path, title="validation PSNR against training time", cpu: bool = False) -> list[dict]:
    """One plot of several checkpoints' learning curves (from MODEL.last.pt's history when present); a
    closed-form baseline (one history entry) is drawn as a horizontal line. Returns the rows plotted."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    rows = []
    for m in models:
        m = Path(m)
        src = checkpoint.last_path(m) if checkpoint.last_path(m).is_file() else m
        ck = checkpoint.load(src)
        h = ck["history"]
        label = f"{ck['arch']['variant']} ({m.stem}, {ck.get('params', 0) / 1000:.0f}k)"
        if ck.get("kind") == "linear":
            ax.axhline(h[-1]["val_psnr"], ls=":", color="k", label=f"linear baseline {h[-1]['val_psnr']:.2f} dB")
        else:
            ax.plot([e["cpu_minutes" if cpu else "minutes"] for e in h], [e["val_psnr"] for e in h], "-", label=label)
        best = max(h, key=lambda e: e["val_psnr"])
        rows.append(dict(model=str(m), variant=ck["arch"]["variant"], params=ck.get("params"), best_val_psnr=best["val_psnr"],
                         best_val_tm_psnr=best.get("val_tm_psnr"), best_val_ssim=best.get("val_ssim"),
                         minutes=h[-1]["minutes"], epochs=h[-1]["epoch"]))
    _finish_plot(fig, ax, path, title, "val PSNR, linear clamped (dB)", fontsize=8,
                 xlabel="training CPU minutes (all threads)" if cpu else "training minutes")
    return rows
