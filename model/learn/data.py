"""A dataset folder (``DIR/manifest.json`` + ``DIR/000042.exr``) as in-memory torch tensors (bpy-free).

The whole dataset is read once (300 samples of 240x135 are ~0.6 GB as float32 inputs). Each sample becomes
``x`` (C x H x W, ``normalize.to_inputs`` for the input spec) and ``y`` (3 x H x W, the Cycles reference in
linear HDR RGB). A sample whose reference has a non-finite pixel is left out with a warning (it would poison
the loss); its key is listed in ``skipped``. Inputs are repaired by normalize's rule and the repaired pixels
counted in ``repaired``. ``mask`` marks the geometry pixels (normalize.geometry_mask of depth and normal):
pixels where nothing was hit show the world, which no input describes, so the loss, the validation metrics
and the baseline's fit leave them out (the SSGI node composites the world there).

Train and validation are split by scene (``split_scenes``): samples of one scene never sit on both sides.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from .. import channels as ch
from ..dataset import exrio
from .. import normalize
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
    mask: torch.Tensor | None = None  # H x W bool: geometry pixels (normalize.geometry_mask); None = all


@dataclass
class DatasetFolder(torch.utils.data.Dataset):
    """All samples of a dataset folder in memory. ``self[i]`` -> (x, y) tensors of one whole sample."""
    root: Path
    spec: tuple[str, ...]
    samples: list[Sample] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    manifest: dict = field(default_factory=dict)

    @classmethod
    def load(cls, root, spec=ch.DEFAULT_INPUTS, keys=None, progress=None) -> "DatasetFolder":
        root = Path(root)
        spec = ch.parse_spec(spec)
        m = folder.open_folder(root, scenes=True)
        groups = tuple(dict.fromkeys(ch.required_groups(spec) + ("normal", "depth", ch.TARGET_GROUP)))
        lacking = [g for g in groups if g not in folder.stored_groups(m)]
        if lacking:
            raise UserError(f"{root / folder.MANIFEST}: this dataset was baked without the group(s) "
                            f"{', '.join(lacking)} that the inputs {ch.format_spec(spec)!r} need; bake it again "
                            f"with this version, or leave those inputs out (--inputs)")
        ds = cls(root=root, spec=spec, manifest=m)
        items = sorted(m["samples"].items())
        if keys is not None:
            keys = set(keys)
            items = [kv for kv in items if kv[0] in keys]
        if not items:
            raise UserError(f"{root / 'manifest.json'}: the manifest lists no samples")
        it = items
        if progress:
            it = progress(items)
        for key, meta in it:
            path = folder.sample_path(root, key)
            if not path.is_file():
                raise UserError(f"{path}: listed in the manifest but missing (re-run `cli.py bake` to complete it)")
            g = exrio.read_sample(path, groups)
            y = normalize.target(g)
            if not np.isfinite(y).all():
                ds.skipped[key] = f"{int((~np.isfinite(y)).any(axis=-1).sum())} non-finite reference pixel(s)"
                continue
            x, rep = normalize.to_inputs(g, spec)
            mask = normalize.geometry_mask(g["depth"], g["normal"])
            ds.samples.append(Sample(key, str(meta["scene"]), torch.from_numpy(x).permute(2, 0, 1).contiguous(),
                                     torch.from_numpy(np.ascontiguousarray(y)).permute(2, 0, 1).contiguous(), rep,
                                     torch.from_numpy(mask)))
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

    def identity(self) -> dict:
        """What names this dataset in a checkpoint."""
        return dict(path=str(self.root.resolve()), manifest_sha256=folder.manifest_sha256(self.root),
                    n_samples=len(self.samples), skipped=dict(self.skipped),
                    format_version=self.manifest.get("format_version"),
                    blender_version=self.manifest.get("blender_version"),
                    settings=self.manifest.get("settings", {}))
