"""Training batches (bpy-free): the epoch plan, each rank's share of it, the crops, worker-process loading and the
memory-bounded sample cache.

- Plan: at the start of an epoch one seeded generator (the Trainer's, stored in the checkpoint) draws the order
  of ``crops_per_image`` crops of every training image and, for each, its corner and left-right flip:
  ``(sample index, y0, x0, flip)``. Every rank draws the same plan; rank ``r`` of ``w`` builds the crops at
  positions ``r, r + w, ...`` of each global batch of ``cfg.batch`` crops. So the crops of a run are a function of
  the seed only: reproducible for a fixed process count, the same crops for any process count, and resuming
  with another process count continues the same plan.
- Loading: ``loader(...)`` iterates this rank's batches in the calling process (``workers`` 0) or in
  ``workers`` persistent worker processes (torch DataLoader, which overlap reading and cropping with the step).
- Samples: in memory (``data.DatasetFolder.load``, the default) or read on demand through ``SampleCache``
  (``--cache-mb``): an LRU of built samples bounded in bytes. The bound applies per process: the training
  process and each worker hold their own cache (a rank uses at most (1 + workers) x cache-mb for samples).
  A lazily read sample whose reference has non-finite pixels keeps them out of the loss and metrics by its
  mask (the in-memory loader leaves such a sample out when it loads).
"""
from __future__ import annotations

import math
from collections import OrderedDict
from pathlib import Path

import numpy as np
import torch

from .. import channels as ch, normalize
from ..dataset import exrio, folder
from ..errors import UserError
from . import data


def plan(gen: torch.Generator, sizes: list[tuple[int, int]], cpi: int, batch: int, crop) -> list[list[tuple]]:
    """One epoch's global batches of (sample index, y0, x0, flip)."""
    ch_, cw = crop
    n = len(sizes)
    order = (torch.randperm(n * cpi, generator=gen) % n).tolist()
    out = []
    for b in range(math.ceil(len(order) / batch)):
        specs = []
        for i in order[b * batch:(b + 1) * batch]:
            H, W = sizes[i]
            y0 = int(torch.randint(0, H - ch_ + 1, (1,), generator=gen))
            x0 = int(torch.randint(0, W - cw + 1, (1,), generator=gen))
            flip = bool(torch.randint(0, 2, (1,), generator=gen))
            specs.append((i, y0, x0, flip))
        out.append(specs)
    return out


def share(batches, rank: int, world: int) -> list[list[tuple]]:
    return [b[rank::world] for b in batches]


class Crops(torch.utils.data.Dataset):
    """``self[specs]`` -> (x N x C x h x w channels_last, y N x 3 x h x w, mask N x 1 x h x w float, sample indices)."""

    def __init__(self, samples, spec, crop):
        self.samples, self.spec, self.crop = samples, tuple(spec), crop

    def __len__(self):
        return len(self.samples)

    def __getitem__(self, specs):
        from .validation import geometry
        ch_, cw = self.crop
        xs, ys, ms = [], [], []
        for i, y0, x0, flip in specs:
            s = self.samples[i]
            x = s.x[None, :, y0:y0 + ch_, x0:x0 + cw]
            y = s.y[None, :, y0:y0 + ch_, x0:x0 + cw]
            m = geometry(s)[None, None, y0:y0 + ch_, x0:x0 + cw]
            if flip:
                x = normalize.flip_x(x, self.spec, axis=1)
                y = torch.flip(y, dims=[-1])
                m = torch.flip(m, dims=[-1])
            xs.append(x)
            ys.append(y)
            ms.append(m)
        idx = [s[0] for s in specs]
        if not xs:
            return None, None, None, idx
        return torch.cat(xs).contiguous(memory_format=torch.channels_last), torch.cat(ys), torch.cat(ms).float(), idx


class _Batches(torch.utils.data.Sampler):
    """The sampler of ``loader``: yields this epoch's batch specs (set before each epoch) to the workers."""

    def __init__(self):
        self.batches: list = []

    def __iter__(self):
        return iter(self.batches)

    def __len__(self):
        return len(self.batches)


class Loader:
    """``loader.epoch(batches)`` -> iterator of built batches, in order; the workers persist across epochs."""

    def __init__(self, crops: Crops, workers: int = 0, pin: bool = False):
        self.crops, self.workers = crops, workers
        self.sampler = _Batches()
        self.dl = None
        if workers:
            self.dl = torch.utils.data.DataLoader(crops, batch_size=None, sampler=self.sampler, num_workers=workers,
                                                  persistent_workers=True, pin_memory=pin, prefetch_factor=4)

    def epoch(self, batches):
        if self.dl is None:
            return (self.crops[b] for b in batches)
        self.sampler.batches = list(batches)
        return iter(self.dl)


# ---- the memory-bounded cache -----------------------------------------------------------------------------
class SampleCache:
    """Built samples (data.Sample) by key, least recently used first out, at most ``max_bytes`` of tensors
    (one sample is always kept, however big)."""

    def __init__(self, root, manifest, spec, target, max_bytes: int):
        self.root, self.manifest, self.spec, self.target = Path(root), manifest, tuple(spec), target
        self.groups = data._groups_for(spec, target)
        self.max_bytes = int(max_bytes)
        self.items: OrderedDict[str, data.Sample] = OrderedDict()
        self.bytes = 0
        self.reads = 0

    @staticmethod
    def nbytes(s: data.Sample) -> int:
        return sum(t.numel() * t.element_size() for t in (s.x, s.y, s.mask) if t is not None)

    def get(self, key: str, scene: str) -> data.Sample:
        s = self.items.get(key)
        if s is not None:
            self.items.move_to_end(key)
            return s
        g = exrio.read_sample(folder.sample_path(self.root, key), self.groups)
        y = normalize.target(g, self.target)
        bad = ~np.isfinite(y).all(axis=-1)
        if bad.any():  # keep it out of the loss and metrics by its mask
            g = dict(g)
            g[self.target] = np.where(bad[..., None], 0.0, y).astype(np.float32)
        s = data.make_sample(key, scene, g, self.spec, self.target)
        if bad.any():
            s.mask = s.mask & ~torch.from_numpy(bad)
        self.reads += 1
        self.items[key] = s
        self.bytes += self.nbytes(s)
        while self.bytes > self.max_bytes and len(self.items) > 1:
            _, old = self.items.popitem(last=False)
            self.bytes -= self.nbytes(old)
        return s


class LazySample:
    """A sample of a dataset folder read on first use through a SampleCache (``x``, ``y``, ``mask`` as data.Sample)."""
    repaired = 0

    def __init__(self, key, scene, hw, cache):
        self.key, self.scene, self.hw, self.cache = key, scene, hw, cache

    x = property(lambda self: self.cache.get(self.key, self.scene).x)
    y = property(lambda self: self.cache.get(self.key, self.scene).y)
    mask = property(lambda self: self.cache.get(self.key, self.scene).mask)


def hw(s) -> tuple[int, int]:
    """(H, W) of a sample without reading a lazy one."""
    return tuple(s.hw) if isinstance(s, LazySample) else tuple(s.x.shape[1:])


def load_lazy(root, spec, cache_mb: float, target: str | None = None) -> data.DatasetFolder:
    """A DatasetFolder of LazySamples sharing one SampleCache of ``cache_mb`` MB; sizes from the manifest.
    ``root``: one folder (or a list of one; several folders are read in memory only, for now)."""
    if not isinstance(root, (str, Path)):
        roots = list(root)
        if len(roots) != 1:
            raise UserError(f"--cache-mb reads one --data folder (got {len(roots)}); merge the folders' samples "
                            "into one (cli.py merge) or train them in memory without --cache-mb")
        root = roots[0]
    root = Path(root)
    spec = ch.parse_spec(spec)
    m = folder.open_folder(root, scenes=True)
    target = ch.check_target(target or data.default_target(m))
    groups = data._groups_for(spec, target)
    data._check_stored(root, m, groups, spec)
    size = (m.get("settings") or {}).get("size")
    if not size:
        raise UserError(f"{root / folder.MANIFEST}: settings.size is missing; --cache-mb needs the sample size")
    for key in m["samples"]:
        if not folder.sample_path(root, key).is_file():
            raise UserError(f"{folder.sample_path(root, key)}: listed in the manifest but missing "
                            "(re-run `cli.py bake` to complete it)")
    cache = SampleCache(root, m, spec, target, cache_mb * 2 ** 20)
    samples = [LazySample(k, str(v["scene"]), (int(size[1]), int(size[0])), cache)
               for k, v in sorted(m["samples"].items())]
    if not samples:
        raise UserError(f"{root / folder.MANIFEST}: the manifest lists no samples")
    return data.DatasetFolder(root=root, spec=spec, samples=samples, manifest=m, target=target)
