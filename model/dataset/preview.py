"""The contact sheet of a dataset folder (``cli.py preview``, bpy-free): one row per sample, one column per
stored group, each group drawn in its own style (tonemapped light, normals as colour, depth as grey)."""
from __future__ import annotations

import numpy as np

from .. import channels as ch, files, images
from . import exrio, folder as folder_
from ..errors import UserError


def _tile(group: str, a: np.ndarray) -> np.ndarray:
    style = ch.GROUPS[group].preview
    if style == "normal":
        return (np.clip(a * 0.5 + 0.5, 0, 1) * 255).astype(np.uint8)
    if style == "depth":
        d = a[..., 0]
        fin = d[np.isfinite(d) & (d < 1e4)]
        s = float(np.median(fin)) if fin.size else 1.0
        v = d / (d + s)
        return (np.repeat(np.clip(1 - v, 0, 1)[..., None], 3, -1) * 255).astype(np.uint8)
    if style == "grey":
        return (np.repeat(np.clip(a[..., :1], 0, 1), 3, -1) * 255).astype(np.uint8)
    if style == "color":
        return images.srgb8(a / np.maximum(1e-6, 1 - np.clip(a, 0, 0.999)))  # show albedo as is
    return images.srgb8(a[..., :3])


def columns(manifest: dict) -> tuple[str, ...]:
    """The sheet's columns: every group the dataset's samples hold, in the channel spec's order (reference last)."""
    return tuple(g for g in ch.SAMPLE_GROUPS if g in folder_.stored_groups(manifest))


def preview(folder, out, max_samples: int = 12) -> dict:
    """Contact sheet: one row per sample, columns = the stored groups (tonemapped), reference last."""
    from PIL import Image, ImageDraw

    m = folder_.open_folder(folder, shards=True)
    names = sorted(m["samples"])[:max_samples]
    if not names:
        raise UserError(f"{folder}: dataset has no samples to preview")
    cols = columns(m)
    rows = []
    for n in names:
        g = exrio.read_sample(folder_.sample_path(folder, n), cols)
        rows.append(np.concatenate([_tile(c, g[c]) for c in cols], axis=1))
    sheet = np.concatenate(rows, axis=0)
    label_h = 14
    img = Image.new("RGB", (sheet.shape[1], sheet.shape[0] + label_h), (0, 0, 0))
    img.paste(Image.fromarray(sheet), (0, label_h))
    d = ImageDraw.Draw(img)
    w = sheet.shape[1] // len(cols)
    for i, c in enumerate(cols):
        d.text((i * w + 3, 1), c, fill=(255, 255, 255))
    out = files.atomic_write(out, lambda tmp: img.save(tmp, format="PNG"))
    return {"sheet": str(out), "samples": len(names)}

