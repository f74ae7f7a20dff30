"""Dataset folders (bpy-free): the manifest, verification, shard merging and the contact sheet.

A dataset folder holds ``manifest.json`` and one EXR per sample named by its index (``000042.exr``, see
``exrio``). A shard of a farm bake (``bake --shard i/n``) writes ``manifest.shard-i-of-n.json`` instead;
``merge`` joins the shard manifests into ``manifest.json``. Every manifest is written atomically.

manifest.json::

    {"format_version": 1, "blender_version": "5.0.1", "channel_spec": [...], "normalisation": {...},
     "settings": {"kind": "rooms"|"scenes", "size": [240, 135], "ref_samples": 4096, "ref_target_db": 41.0,
                  "denoise": false, ...},
     "samples": {"000042": {"seed": 42, "scene": "room-42", "camera": ..., "frame": ..., "timings": {...},
                            "reference": {"samples": 1024, "agreement_db": 42.4, "renders": 6}}}}

``ref_target_db`` null: every reference took exactly ``ref_samples`` (``agreement_db`` null). Older bakes have
neither key.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from .. import channels as ch, files
from . import exrio
from ..errors import UserError

MANIFEST = "manifest.json"
SAMPLE_RE = re.compile(r"^(\d{6})\.exr$")
# settings that must agree for samples to share one folder
IDENTITY_SETTINGS = ("kind", "size", "ref_samples", "ref_target_db", "denoise", "eevee_samples", "diffuse_bounces", "first_seed",
                     "scenes", "frames", "half")


def sample_name(index: int) -> str:
    return f"{int(index):06d}"


def sample_path(folder, name: str) -> Path:
    return Path(folder) / f"{name}.exr"


def shard_manifest_name(shard: tuple[int, int] | None) -> str:
    return MANIFEST if shard is None else f"manifest.shard-{shard[0]}-of-{shard[1]}.json"


def new_manifest(settings: dict, blender_version: str) -> dict:
    return {"format_version": ch.FORMAT_VERSION, "blender_version": blender_version,
            "channel_spec": ch.describe(), "settings": dict(settings), "samples": {}}


def read_manifest(path) -> dict:
    """Read and check one manifest file. UserError names the file and the fault."""
    path = Path(path)
    try:
        m = json.loads(path.read_text())
    except FileNotFoundError:
        raise UserError(f"{path}: no manifest (is this a dataset folder?)") from None
    except (OSError, ValueError) as e:
        raise UserError(f"{path}: not a readable manifest ({e})") from None
    if not isinstance(m, dict) or "format_version" not in m or not isinstance(m.get("samples"), dict):
        raise UserError(f"{path}: not an SSGI dataset manifest (no format_version, or no 'samples' table)")
    v = m["format_version"]
    if not isinstance(v, int) or isinstance(v, bool):
        raise UserError(f"{path}: manifest has no integer 'format_version' ({v!r})")
    if v > ch.FORMAT_VERSION:
        raise UserError(f"{path}: manifest format_version {v} is newer than this SSGI reads ({ch.FORMAT_VERSION}); "
                        "update SSGI")
    if v < ch.FORMAT_VERSION:
        raise UserError(f"{path}: manifest format_version {v} is older than {ch.FORMAT_VERSION}; re-bake the dataset")
    return m


def load_manifest(folder) -> dict:
    return read_manifest(Path(folder) / MANIFEST)


def write_manifest(folder, manifest: dict, name: str = MANIFEST) -> None:
    files.write_json(Path(folder) / name, manifest, indent=1, sort_keys=True, default=float)


def check_compatible(manifest: dict, settings: dict, where) -> None:
    """Refuse to mix samples baked with other settings into one folder."""
    old = manifest.get("settings", {})
    diff = [f"{k}={old.get(k)!r} (not {k}={settings.get(k)!r})" for k in IDENTITY_SETTINGS
            if (k in settings or k in old)
            and json.dumps(old.get(k), sort_keys=True) != json.dumps(settings.get(k), sort_keys=True)]
    if diff:
        raise UserError(f"{where}: holds a dataset baked with {', '.join(diff)}; "
                        f"bake into another folder (datasets of different settings are never mixed)")


def _check_writable(folder: Path) -> None:
    """Write and delete a probe file: os.access says yes to root even on folders that refuse every write
    (read-only mounts aside), so only a real write tells."""
    try:
        files.scratch("ssgi-write-test", folder=folder).unlink()
    except OSError as e:
        raise UserError(f"--out {folder}: folder is not writable ({e.strerror})") from None


def prepare_folder(folder, settings: dict, blender_version: str, shard=None) -> dict:
    """Create or reopen a dataset folder for baking; returns its (shard) manifest. Refuses foreign folders."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"--out {folder}: exists and is not a folder")
    if not folder.exists():
        parent = folder.parent
        if not parent.is_dir():
            raise UserError(f"--out {folder}: parent folder {parent} does not exist")
        try:
            folder.mkdir()
        except OSError as e:
            raise UserError(f"--out {folder}: cannot create the folder in {parent} ({e.strerror})") from None
    _check_writable(folder)
    name = shard_manifest_name(shard)
    mpath = folder / name
    manifests = sorted(folder.glob("manifest*.json"))
    if mpath.exists():
        m = read_manifest(mpath)
        check_compatible(m, settings, mpath)
        return m
    for other in manifests:  # another shard's or the merged manifest: must agree
        check_compatible(read_manifest(other), settings, other)
    if not manifests:
        foreign = [p.name for p in folder.iterdir()
                   if not (SAMPLE_RE.match(p.name) or p.name.endswith(".tmp") or p.name.startswith("."))]
        if foreign:
            raise UserError(f"--out {folder}: not empty and not an SSGI dataset (holds {', '.join(sorted(foreign)[:5])}); "
                            f"choose an empty or new folder")
    return new_manifest(settings, blender_version)


def stored_groups(manifest: dict) -> tuple[str, ...]:
    """The groups every sample of this dataset holds: those its manifest's channel spec lists (a dataset baked
    before an optional group existed does not hold it)."""
    listed = {g.get("name") for g in manifest.get("channel_spec", ()) if isinstance(g, dict) and "channels" in g}
    return tuple(g for g in ch.SAMPLE_GROUPS if g in listed or g not in ch.OPTIONAL_GROUPS)


def check_sample(path, size=None, groups=None) -> list[str]:
    """Problems of one sample file (unreadable, missing channels of ``groups`` (default: every sample group),
    size other than ``size`` = [w, h], non-finite values), each naming the file. Empty when the sample is
    complete and sound."""
    try:
        g = exrio.read_sample(path, tuple(groups) if groups is not None else ch.SAMPLE_GROUPS)
    except UserError as e:
        return [str(e)]
    problems = []
    h, w = g["ref"].shape[:2]
    if size and [w, h] != list(size):
        problems.append(f"{path}: size {w}x{h}, manifest says {size[0]}x{size[1]}")
    for k, v in g.items():
        bad = int((~np.isfinite(v)).sum())
        if bad:
            problems.append(f"{path}: {bad} non-finite value(s) in {k}")
    return problems


def merge(folder) -> dict:
    """Join the shard manifests of ``folder`` (and an existing manifest.json) into manifest.json."""
    folder = Path(folder)
    parts = sorted(folder.glob("manifest.shard-*.json"))
    if not parts:
        raise UserError(f"{folder}: no shard manifests (manifest.shard-*.json) to merge")
    base_path = folder / MANIFEST
    merged = read_manifest(base_path) if base_path.exists() else None
    for p in parts:
        m = read_manifest(p)
        if merged is None:
            merged = {**m, "samples": {}}
            merged["settings"] = {k: v for k, v in m["settings"].items() if k != "shard"}
        else:
            check_compatible(merged, m["settings"], p)
        for name, s in m["samples"].items():
            if name in merged["samples"] and merged["samples"][name].get("seed") != s.get("seed"):
                raise UserError(f"{p}: sample {name} conflicts with another shard's (seed {s.get('seed')} vs "
                                f"{merged['samples'][name].get('seed')})")
            merged["samples"][name] = s
    merged["samples"] = dict(sorted(merged["samples"].items()))
    write_manifest(folder, merged)
    return {"samples": len(merged["samples"]), "shards": [p.name for p in parts]}


def verify(folder) -> list[str]:
    """Check a dataset: manifest against files, channel names and sizes, finite values. Returns problems,
    each naming the file."""
    folder = Path(folder)
    problems: list[str] = []
    try:
        m = load_manifest(folder)
    except UserError as e:
        return [str(e)]
    size = m.get("settings", {}).get("size")
    found = {SAMPLE_RE.match(p.name).group(1): p for p in folder.iterdir() if SAMPLE_RE.match(p.name)}
    for name in sorted(set(m["samples"]) - set(found)):
        problems.append(f"{sample_path(folder, name)}: listed in the manifest but missing")
    for name in sorted(set(found) - set(m["samples"])):
        problems.append(f"{found[name]}: not listed in the manifest (incomplete sample?)")
    for name in sorted(set(found) & set(m["samples"])):
        problems.extend(check_sample(found[name], size, stored_groups(m)))
    temps = sorted(p.name for p in folder.iterdir() if files.TEMP_RE.match(p.name))
    if temps:
        problems.append(f"{folder}: temporary file(s) left over: {', '.join(temps[:5])}")
    return problems


def tonemap8(x: np.ndarray) -> np.ndarray:
    """Linear HDR -> 8-bit sRGB for viewing: Reinhard x/(1+x), then the sRGB curve."""
    x = np.nan_to_num(np.maximum(x, 0.0), nan=0.0, posinf=1e4)
    t = x / (1.0 + x)
    s = np.where(t <= 0.0031308, 12.92 * t, 1.055 * np.power(t, 1 / 2.4) - 0.055)
    return (np.clip(s, 0, 1) * 255 + 0.5).astype(np.uint8)


def _tile(group: str, a: np.ndarray) -> np.ndarray:
    if group == "normal":
        return (np.clip(a * 0.5 + 0.5, 0, 1) * 255).astype(np.uint8)
    if group == "depth":
        d = a[..., 0]
        fin = d[np.isfinite(d) & (d < 1e4)]
        s = float(np.median(fin)) if fin.size else 1.0
        v = d / (d + s)
        return (np.repeat(np.clip(1 - v, 0, 1)[..., None], 3, -1) * 255).astype(np.uint8)
    if group in ("ao",):
        return (np.repeat(np.clip(a, 0, 1), 3, -1) * 255).astype(np.uint8)
    if group == "albedo":
        return tonemap8(a / np.maximum(1e-6, 1 - np.clip(a, 0, 0.999)))  # show albedo as is
    return tonemap8(a[..., :3])


def load_samples_manifest(folder) -> dict:
    """manifest.json, or while a farm bake runs (no merge yet) the union of its shard manifests, read-only."""
    folder = Path(folder)
    parts = sorted(folder.glob("manifest.shard-*.json"))
    if (folder / MANIFEST).exists() or not parts:
        return load_manifest(folder)
    ms = [read_manifest(p) for p in parts]
    return {**ms[0], "samples": dict(sorted(kv for m in ms for kv in m["samples"].items()))}


def preview(folder, out, max_samples: int = 12) -> dict:
    """Contact sheet: one row per sample, columns = the stored groups (tonemapped), reference last."""
    from PIL import Image, ImageDraw

    m = load_samples_manifest(folder)
    names = sorted(m["samples"])[:max_samples]
    if not names:
        raise UserError(f"{folder}: dataset has no samples to preview")
    cols = tuple(g for g in ("albedo", "normal", "depth", "direct", "ao", "world", "eevee", "ref")
                 if g in stored_groups(m))
    rows = []
    for n in names:
        g = exrio.read_sample(sample_path(folder, n), cols)
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

