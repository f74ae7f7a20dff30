"""A dataset folder (``DIR/manifest.json`` + ``DIR/000042.exr``) as in-memory torch tensors (bpy-free).

The whole dataset is read once (300 samples of 240x135 are ~0.6 GB as float32 inputs). Each sample becomes
``x`` (C x H x W, ``normalize.to_inputs`` for the input spec) and ``y`` (3 x H x W, the Cycles reference in
linear HDR RGB). A sample whose reference has a non-finite pixel is left out with a warning (it would poison
the loss); its key is listed in ``skipped``. Inputs are repaired by normalize's rule and the repaired pixels
counted in ``repaired``. ``mask`` marks the geometry pixels (images.geometry_mask of depth and normal):
pixels where nothing was hit show the world, which no input describes, so the loss, the validation metrics
and the baseline's fit leave them out (the SSGI node composites the world there).

Train and validation are split by scene (``split_scenes``): samples of one scene never sit on both sides; or
by an explicit list of keys (the fit's views of one scene: ``Trainer(split=...)``).

Several folders train together (``load_folders``, ``cli.py train --data A B``): each folder is split by its own
scenes with the same fraction and seed, so a folder's validation scenes are the ones it has when trained alone,
and its samples' keys and scenes are prefixed with the folder's name (``artist1/000042``).

``read_samples`` is the one reader of sample files and ``make_sample`` the one builder of a sample for an input
spec: ``DatasetFolder.load`` builds each sample as it is read (training); ``StoredSamples`` keeps the stored
groups to build samples for many specs (the fit).
"""
from __future__ import annotations

import dataclasses
import hashlib
import random
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from .. import channels as ch
from ..dataset import exrio
from .. import images, normalize
from ..dataset import folder
from ..errors import UserError


def split_scenes(scenes, val_fraction: float = 0.2, seed: int = 0) -> tuple[list[str], list[str]]:
    """Deterministic split of scene ids into (train, val); at least one scene on each side."""
    scenes = sorted({str(s) for s in scenes})
    if len(scenes) < 2:
        raise UserError(f"the dataset has {len(scenes)} scene(s); a train/validation split by scene needs at least 2")
    rng = random.Random(seed)
    order = scenes[:]
    rng.shuffle(order)
    n_val = min(len(scenes) - 1, max(1, round(val_fraction * len(scenes))))
    return sorted(order[n_val:]), sorted(order[:n_val])


@dataclass
class Sample:
    key: str
    scene: str
    x: torch.Tensor  # C x H x W normalised inputs
    y: torch.Tensor  # 3 x H x W linear HDR reference
    repaired: int = 0
    mask: torch.Tensor | None = None  # H x W bool: geometry pixels (images.geometry_mask); None = all


def _groups_for(spec, target: str = ch.TARGET_GROUP) -> tuple[str, ...]:
    """The stored groups a sample for ``spec`` is built from: the spec's, plus the normals and depth (the
    geometry mask; normals also mark the background for the depth normalisation, as the render path does) and
    the ``target`` reference."""
    return tuple(dict.fromkeys(ch.required_groups(spec) + ("normal", "depth") + ch.target_groups(target)))


def default_target(manifest: dict) -> str:
    """What a model trained on this dataset learns unless told: the diffuse part (``ref_diffuse``) when the
    samples hold it, else the whole image (``ref``, the first datasets)."""
    return ch.DIFFUSE_TARGET if ch.DIFFUSE_TARGET in folder.stored_groups(manifest) else ch.TARGET_GROUP


def _check_stored(root: Path, manifest: dict, groups, spec) -> None:
    lacking = [g for g in groups if g not in folder.stored_groups(manifest)]
    if lacking:
        raise UserError(f"{root / folder.MANIFEST}: this dataset was baked without the group(s) "
                        f"{', '.join(lacking)} that the inputs {ch.format_spec(spec)!r} need; bake it again "
                        f"with this version, or leave those inputs out (--inputs)")


def read_samples(root, manifest: dict, groups, keys=None, progress=None, skipped=None, target: str = ch.TARGET_GROUP):
    """The one reader of sample files: yields (key, scene, {group: HxWxC}) for the samples of ``keys`` (default:
    all; a key the manifest does not list is a UserError) in key order. A sample whose reference has a
    non-finite pixel is not yielded; its key and why go into ``skipped``."""
    root = Path(root)
    items = sorted(manifest["samples"].items())
    if keys is not None:
        keys = sorted(set(map(str, keys)))
        unknown = [k for k in keys if k not in manifest["samples"]]
        if unknown:
            raise UserError(f"{root / folder.MANIFEST}: lists no sample {unknown[0]!r}")
        items = [(k, manifest["samples"][k]) for k in keys]
    if not items:
        raise UserError(f"{root / folder.MANIFEST}: the manifest lists no samples")
    for key, meta in (progress(items) if progress else items):
        path = folder.sample_path(root, key)
        if not path.is_file():
            raise UserError(f"{path}: listed in the manifest but missing (re-run `cli.py bake` to complete it)")
        g = exrio.read_sample(path, groups)
        y = normalize.target(g, target)
        if not np.isfinite(y).all():
            if skipped is not None:
                skipped[key] = f"{int((~np.isfinite(y)).any(axis=-1).sum())} non-finite reference pixel(s)"
            continue
        yield key, str(meta["scene"]), g


def make_sample(key: str, scene: str, g: dict, spec, target: str = ch.TARGET_GROUP) -> Sample:
    """One training sample from a sample's stored groups, built the way the Predictor builds its input; its
    ``y`` is the ``target`` group."""
    x, rep = normalize.to_inputs(g, spec)
    y = np.ascontiguousarray(normalize.target(g, target))
    mask = images.geometry_mask(g["depth"], g["normal"])
    return Sample(key, scene, torch.from_numpy(x).permute(2, 0, 1).contiguous(),
                  torch.from_numpy(y).permute(2, 0, 1).contiguous(), rep, torch.from_numpy(mask))


@dataclass
class DatasetFolder(torch.utils.data.Dataset):
    """All samples of a dataset folder in memory. ``self[i]`` -> (x, y) tensors of one whole sample."""
    root: Path
    spec: tuple[str, ...]
    samples: list[Sample] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    manifest: dict = field(default_factory=dict)
    target: str = ch.TARGET_GROUP  # the group the samples' y holds (channels.TARGETS)

    @classmethod
    def load(cls, root, spec=ch.DEFAULT_INPUTS, keys=None, progress=None, target: str | None = None) -> "DatasetFolder":
        """Read the samples of ``keys`` (default: all) and build them for ``spec``, one at a time (the stored
        groups are not kept). ``target``: the group to learn (None: ``default_target`` of the dataset)."""
        root = Path(root)
        spec = ch.parse_spec(spec)
        m = folder.open_folder(root, scenes=True)
        target = ch.check_target(target or default_target(m))
        groups = _groups_for(spec, target)
        _check_stored(root, m, groups, spec)
        ds = cls(root=root, spec=spec, manifest=m, target=target)
        for key, scene, g in read_samples(root, m, groups, keys, progress, ds.skipped, target):
            ds.samples.append(make_sample(key, scene, g, spec, target))
        if not ds.samples:
            raise UserError(f"{root}: no usable sample (skipped: {ds.skipped})")
        return ds

    def __len__(self):
        return len(self.samples)

    def __getitem__(self, i):
        s = self.samples[i]
        return s.x, s.y

    @property
    def scenes(self) -> list[str]:
        return sorted({s.scene for s in self.samples})

    @property
    def repaired(self) -> int:
        return sum(s.repaired for s in self.samples)

    def subset(self, scenes) -> list[Sample]:
        scenes = set(scenes)
        return [s for s in self.samples if s.scene in scenes]

    def split(self, val_fraction: float, seed: int) -> tuple[list[str], list[str]]:
        """(train scenes, validation scenes): ``split_scenes`` of this folder's scenes."""
        return split_scenes(self.scenes, val_fraction, seed)

    def identity(self) -> dict:
        """What names this dataset in a checkpoint."""
        return dict(path=str(self.root.resolve()), manifest_sha256=folder.manifest_sha256(self.root),
                    n_samples=len(self.samples), skipped=dict(self.skipped),
                    format_version=self.manifest.get("format_version"),
                    blender_version=self.manifest.get("blender_version"),
                    settings=self.manifest.get("settings", {}))


@dataclass
class FolderSet(DatasetFolder):
    """Several dataset folders as one training set (``load_folders``): ``parts`` are the folders, loaded
    alone; ``samples`` are theirs with the keys and scenes prefixed ``<tag>/``."""
    parts: list = field(default_factory=list)
    tags: list = field(default_factory=list)

    def split(self, val_fraction: float, seed: int) -> tuple[list[str], list[str]]:
        train, val = [], []
        for tag, part in zip(self.tags, self.parts):
            tr, va = part.split(val_fraction, seed)
            train += [f"{tag}/{s}" for s in tr]
            val += [f"{tag}/{s}" for s in va]
        return sorted(train), sorted(val)

    def identity(self) -> dict:
        parts = [p.identity() for p in self.parts]
        digest = hashlib.sha256("".join(p["manifest_sha256"] for p in parts).encode()).hexdigest()
        return dict(path=[p["path"] for p in parts], manifest_sha256=digest, n_samples=len(self.samples),
                    skipped=dict(self.skipped), folders=parts, tags=list(self.tags))


def recorded_split(ident: dict | None, sha: str | None = None, path: str | None = None) -> dict | None:
    """The split {train, val} (scene lists) that a checkpoint's ``dataset`` record gives the folder with
    manifest ``sha`` or resolved ``path``: its own split, or, for a model trained on several folders, that
    folder's part with the ``<tag>/`` prefixes taken off; None when the record names no such folder.
    ``sha`` and ``path`` both None: the train scenes of every folder, unprefixed (what the model has seen)."""
    ident = ident or {}
    split = ident.get("split") or {}
    if "folders" not in ident:
        if sha is None and path is None or ident.get("manifest_sha256") == sha or ident.get("path") == path:
            return dict(train=list(split.get("train") or ()), val=list(split.get("val") or ()))
        return None
    tags = ident.get("tags") or []
    hits = [t for t, part in zip(tags, ident["folders"])
            if sha is None and path is None or part.get("manifest_sha256") == sha or part.get("path") == path]
    if not hits:
        return None
    pre = tuple(f"{t}/" for t in hits)
    strip = (lambda names: [n.split("/", 1)[1] for n in names or () if n.startswith(pre)])
    return dict(train=strip(split.get("train")), val=strip(split.get("val")))


def _tags(roots) -> list[str]:
    """A short unique name per folder: its name, with its parent's when two folders share a name."""
    names = [r.name or str(r) for r in roots]
    out = [f"{r.parent.name}.{n}" if names.count(n) > 1 else n for r, n in zip(roots, names)]
    if len(set(out)) < len(out):
        raise UserError(f"--data: the same folder is given twice ({', '.join(map(str, roots))})")
    return out


def load_folders(roots, spec=ch.DEFAULT_INPUTS, progress=None, target: str | None = None) -> DatasetFolder:
    """One folder (a str or a list of one): ``DatasetFolder.load``. Several: a ``FolderSet``. ``target`` None:
    ``ref_diffuse`` when every folder stores it, else ``ref``."""
    roots = [Path(roots)] if isinstance(roots, (str, Path)) else [Path(r) for r in roots]
    if not roots:
        raise UserError("--data: no dataset folder given")
    if len(roots) == 1:
        return DatasetFolder.load(roots[0], spec, progress=progress, target=target)
    tags = _tags(roots)
    if target is None:
        targets = {default_target(folder.open_folder(r, scenes=True)) for r in roots}
        target = ch.DIFFUSE_TARGET if targets == {ch.DIFFUSE_TARGET} else ch.TARGET_GROUP
    parts = [DatasetFolder.load(r, spec, progress=progress, target=target) for r in roots]
    fs = FolderSet(root=roots[0], spec=parts[0].spec, manifest=parts[0].manifest, target=target,
                   parts=parts, tags=tags)
    for tag, part in zip(tags, parts):
        fs.samples += [dataclasses.replace(s, key=f"{tag}/{s.key}", scene=f"{tag}/{s.scene}") for s in part.samples]
        fs.skipped.update({f"{tag}/{k}": why for k, why in part.skipped.items()})
    return fs


class StoredSamples:
    """The stored groups of some samples of a dataset folder, read once and kept, to build samples for many
    input specs (the fit's size search and input ablation) without reading the files again. ``raw``:
    {key: {group: HxWxC}}, every stored input group plus normal, depth, the reference and the EEVEE groups a
    prediction is composed with (``channels.base_group``: the node's image that fit_report.score_node scores)."""

    def __init__(self, root, keys=None, log=None):
        self.root = Path(root)
        self.manifest = folder.open_folder(self.root, scenes=True)
        stored = folder.stored_groups(self.manifest)
        composed = tuple(ch.base_group(t) for t in ch.TARGETS if ch.adds_part(t))
        groups = tuple(g for g in dict.fromkeys(_groups_for(ch.INPUT_GROUPS) + tuple(
            s for t in ch.TARGETS for s in ch.target_groups(t)) + composed) if g in stored)
        self.target = default_target(self.manifest)
        self.skipped: dict[str, str] = {}
        self.raw = {k: g for k, _scene, g in read_samples(self.root, self.manifest, groups, keys, skipped=self.skipped)}
        self.scene = {k: str(self.manifest["samples"][k]["scene"]) for k in self.raw}
        for k, why in self.skipped.items():
            if log:
                log(f"view {k}: left out ({why})")

    @property
    def size(self) -> tuple[int, int]:
        """(H, W) of the samples; UserError when they differ."""
        sizes = {v[ch.TARGET_GROUP].shape[:2] for v in self.raw.values()}
        if len(sizes) > 1:
            raise UserError(f"{self.root}: samples have different sizes {sorted(sizes)}")
        return next(iter(sizes)) if sizes else (0, 0)

    def keys(self, keys) -> list[str]:
        """The usable ones of ``keys`` (not skipped), sorted."""
        return [k for k in sorted(set(map(str, keys))) if k in self.raw]

    def samples(self, spec, keys, target: str | None = None) -> list[Sample]:
        spec = ch.parse_spec(spec)
        target = ch.check_target(target or self.target)
        _check_stored(self.root, self.manifest, _groups_for(spec, target), spec)
        return [make_sample(k, self.scene[k], self.raw[k], spec, target) for k in self.keys(keys)]

    def dataset(self, spec, keys, target: str | None = None) -> DatasetFolder:
        spec = ch.parse_spec(spec)
        target = ch.check_target(target or self.target)
        return DatasetFolder(root=self.root, spec=spec, manifest=self.manifest, skipped=dict(self.skipped),
                             samples=self.samples(spec, keys, target), target=target)
