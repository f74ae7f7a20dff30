"""The dataset format's one owner (bpy-free): the settings schema, sample paths, the manifest readers and
writer, verification and shard merging. (The contact sheet is ``preview.py``; a sample's channels ``exrio.py``.)

A dataset folder holds ``manifest.json`` and one EXR per sample named by its key (``000042.exr``,
``sample_path``). A shard of a farm bake (``bake --shard i/n``) writes ``manifest.shard-i-of-n.json`` instead;
``merge`` joins the shard manifests into ``manifest.json``. Every manifest is written atomically.

Reading: ``read_manifest(file)`` checks one manifest file; ``open_folder(folder, shards=..., scenes=...)`` is the
entry for a whole folder (the one every reader uses: training, fit, report, verify, preview, the operators).
Writing: the baker builds its settings with ``settings(...)`` (the keys that make samples comparable are
``IDENTITY_SETTINGS``), opens the folder with ``prepare_folder`` and writes with ``write_manifest``.

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

import hashlib
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
                     "room_mode",
                     "scenes", "frames", "half")


def settings(kind: str, size, ref_samples: int, denoise: bool, eevee_samples: int, *, diffuse_bounces: int,
             eevee: dict, ref_target_db: float | None = None, first_seed: int | None = None, scenes=None, frames=None,
             half: bool = True, room_mode: str = "diffuse") -> dict:
    """The ``settings`` table of a baked dataset's manifest (the schema: module doc). ``eevee``: the G-buffer
    renderer's settings as the baker applies them (written as they are); ``kind`` "rooms" (with ``first_seed``)
    or "scenes" (with ``scenes`` and ``frames``)."""
    s = {"kind": kind, "size": [int(size[0]), int(size[1])], "ref_samples": int(ref_samples),
         "ref_target_db": ref_target_db, "denoise": bool(denoise), "eevee_samples": int(eevee_samples),
         "diffuse_bounces": int(diffuse_bounces), "half": bool(half),
         "cycles": {"adaptive_sampling": False, "clamp_direct": 0.0, "clamp_indirect": 0.0,
                    "denoiser": "OPENIMAGEDENOISE" if denoise else None,
                    "denoising_input_passes": "RGB_ALBEDO_NORMAL" if denoise else None},
         "eevee": dict(eevee)}
    if first_seed is not None:
        s["first_seed"] = int(first_seed)
    if room_mode != "diffuse":  # a folder of the seed's diffuse rooms records none (as before the modes existed)
        s["room_mode"] = str(room_mode)
    if scenes is not None:
        s["scenes"] = [str(x) for x in scenes]
        s["frames"] = frames
    return s


def sample_name(index: int) -> str:
    return f"{int(index):06d}"


def sample_path(folder, key: str) -> Path:
    """The one rule for a sample's file: ``FOLDER/KEY.exr``."""
    return Path(folder) / f"{key}.exr"


def shard_manifest_name(shard: tuple[int, int] | None) -> str:
    return MANIFEST if shard is None else f"manifest.shard-{shard[0]}-of-{shard[1]}.json"


def new_manifest(settings: dict, blender_version: str, groups=None) -> dict:
    """A manifest with no samples yet; its channel spec lists ``groups`` (the groups every sample will hold;
    None: all of channels.SAMPLE_GROUPS)."""
    return {"format_version": ch.FORMAT_VERSION, "blender_version": blender_version,
            "channel_spec": ch.describe(groups), "settings": dict(settings), "samples": {}}


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
    ch.refuse_gone_bake(m.get("settings"), path.parent)
    return m


def open_folder(folder, shards: bool = False, scenes: bool = False) -> dict:
    """The manifest of dataset folder ``folder``, checked (``read_manifest``). UserError names the fault.

    ``shards``: while a farm bake runs (no merge yet), the union of its shard manifests, read-only.
    ``scenes``: every sample must name its scene (the train/validation split is by scene)."""
    folder = Path(folder)
    path = folder / MANIFEST
    if not folder.is_dir():
        raise UserError(f"{folder}: dataset folder does not exist")
    parts = sorted(folder.glob("manifest.shard-*.json")) if shards and not path.exists() else []
    if parts:
        ms = [read_manifest(p) for p in parts]
        m = {**ms[0], "samples": dict(sorted(kv for m in ms for kv in m["samples"].items()))}
    elif not path.is_file():
        raise UserError(f"{path}: no manifest.json in the dataset folder (bake one with `cli.py bake`)")
    else:
        m = read_manifest(path)
    if scenes:
        for key, s in m["samples"].items():
            if not isinstance(s, dict) or "scene" not in s:
                raise UserError(f"{path}: sample {key!r} has no 'scene' id")
    return m


def manifest_sha256(folder) -> str:
    """What names a dataset's contents in a checkpoint: the hash of its manifest file."""
    return hashlib.sha256((Path(folder) / MANIFEST).read_bytes()).hexdigest()


def write_manifest(folder, manifest: dict, name: str = MANIFEST) -> None:
    files.write_json(Path(folder) / name, manifest, indent=1, sort_keys=True, default=float)


def check_compatible(manifest: dict, settings: dict, where) -> None:
    """Refuse to mix samples baked with other settings into one folder."""
    old = manifest.get("settings", {})
    diff = [f"{k}={old.get(k)!r} (not {k}={settings.get(k)!r})" for k in IDENTITY_SETTINGS
            if (k in settings or k in old)
            and json.dumps(old.get(k), sort_keys=True) != json.dumps(settings.get(k), sort_keys=True)]
    # and the one render of a one-render bake (its GI, its emitter proxies' shadows and sides: the input it holds)
    # (keys set to None, such as a GI-on one render's proxy settings, count as absent: bakes from before a key was
    # added resume)
    one_old, one_new = ({k: v for k, v in ((s.get("eevee") or {}).get("one_render") or {}).items() if v is not None}
                        or None for s in (old, settings))
    if (one_old or one_new) and json.dumps(one_old, sort_keys=True) != json.dumps(one_new, sort_keys=True):
        diff.append(f"eevee.one_render={one_old!r} (not {one_new!r})")
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


def prepare_folder(folder, settings: dict, blender_version: str, shard=None, groups=None) -> dict:
    """Create or reopen a dataset folder for baking; returns its (shard) manifest. Refuses foreign folders."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"--out {folder}: exists and is not a folder")
    if not folder.exists():
        parent = folder.parent
        if not parent.is_dir():
            raise UserError(f"--out {folder}: parent folder {parent} does not exist")
        try:
            folder.mkdir(exist_ok=True)  # shards started side by side each create it: the first one wins
        except OSError as e:
            raise UserError(f"--out {folder}: cannot create the folder in {parent} ({e.strerror})") from None
        if not folder.is_dir():
            raise UserError(f"--out {folder}: exists and is not a folder")
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
    return new_manifest(settings, blender_version, groups)


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
        m = open_folder(folder)
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
