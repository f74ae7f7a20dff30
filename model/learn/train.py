"""Training (torch, bpy-free): ``Trainer(TrainConfig(...)).run(callback=..., should_stop=...)``.

Used by ``cli.py train`` and by the Blender "Train" operator's worker thread (it never touches bpy).

Why this module stays whole (~480 lines): it is the training loop (its config and one class), whose resume state, lr
schedule, NaN guard and checkpoints share the same fields (step, epoch, snapshot, lr scale, quarantine) and one
invariant (a resumed run equals an uninterrupted one); split, those fields would be written in one module and
read in another. What is not the loop is elsewhere: validation metrics (validation.py), learning curves
(curves.py), checkpoints (checkpoint.py), samples (data.py), the epoch plan, crops, loader workers and the
sample cache (batches.py), the processes under torchrun and their collectives (distributed.py).

- Data: the whole dataset folder in memory (data.DatasetFolder), or read on demand through a bounded cache
  (``cache_mb``, batches.load_lazy); train/validation split by scene (data.split_scenes, seeded), recorded in
  the checkpoint.
- Processes: one, or N under ``torchrun`` (DistributedDataParallel; docs/training_distributed.md): ``batch`` is
  the global batch, every rank draws the same seeded plan and trains on its share, the loss is normalised by the
  global pixel count, every guard decides on all-reduced values, rank 0 validates and writes the checkpoints.
  Device: ``device`` (CUDA when present), ``amp`` (bf16 autocast of the forward pass on CUDA).
- Batches: random ``crop`` x ``crop`` crops of training images, each mirrored left-right with p = 0.5
  (normalize.flip_x negates normal.x), drawn for the whole epoch at its start (batches.plan). One epoch =
  ``crops_per_image`` crops of every training image (default: image area / crop area, so an epoch sees about as
  many pixels as the training set has).
- Loss: mean squared error in log1p space, ``mean((net(x) - log1p(ref))^2)`` over the geometry pixels
  (data.Sample.mask; where nothing was hit the world shows, which no input describes): log1p compresses
  bright lights (1e3 -> 6.9) so they do not dominate, and is close to linear for the [0, 1] range the PSNR
  scores. Validation metrics (``validation.evaluate``) are pooled over the same pixels.
- Optimizer: Adam (lr 5e-4) by default; ``sgd``: momentum 0.9, lr 1e-2, gradient-norm clipping at ``clip``
  (default 1.0 for SGD, none for Adam). The learning rate follows a cosine from lr to lr/20 over the
  budget (epochs, or minutes when no epoch count is given).
- Checkpoints: after every epoch, ``MODEL.last.pt`` (weights + optimizer + RNG + step, for ``--resume``) is
  written atomically; ``MODEL`` is rewritten only when validation PSNR (seed's convention) improves, so
  MODEL is always the best model so far. A learning-curve PNG ``MODEL.curve.png`` is written beside it.
- Resume: continues from ``MODEL.last.pt`` at the start of the next epoch with the same step count,
  optimizer state and RNG state; on CPU with a fixed seed the result equals an uninterrupted run. The
  stored settings are used, except ``--lr``, ``--clip``, ``--early-stop``, ``--epochs``, ``--minutes`` when
  given again (a diverged run can resume with a lower learning rate).
- Data guard: a batch whose loss is non-finite because a crop holds a non-finite value leaves that sample
  out of training from then on (logged; ``left_out`` in the summary).
- NaN guard: a step whose loss or gradient norm is non-finite (or whose loss exceeds 50x the running mean)
  is skipped. After 3 such steps in a row the weights and optimizer go back to the last good snapshot (taken
every 50 sane losses, before the update) and
  the learning rate is halved; after 6 halvings training stops with a UserError. Weights with a NaN are
  never saved (checkpoint.save refuses them), so the last good checkpoint stays.
- Cancel: ``should_stop()`` is checked before every batch; the last checkpoint stays as it is.
"""
from __future__ import annotations

import copy
import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from .. import channels as ch
from . import batches, checkpoint, curves, data, distributed, network
from .config import ADAM_LR, DEFAULT_MINUTES, SGD_LR, TrainConfig, data_dirs
from .validation import evaluate, geometry
from .. import files, normalize
from ..errors import UserError

SNAPSHOT_EVERY = 50
BAD_STREAK = 3
MAX_LR_DROPS = 6
EXPLODE = 50.0


class Diverged(UserError):
    pass


class Trainer:
    def __init__(self, cfg: TrainConfig, dataset: data.DatasetFolder | None = None, log=None, split=None,
                 init_state: dict | None = None):
        """``split``: (train keys, validation keys) instead of the split by scene (the fit's views of one scene);
        ``init_state``: starting weights (fine-tuning)."""
        cfg.check()
        self.cfg = cfg
        self.dataset = dataset
        self.split = split
        self.init_state = init_state
        self.log = log or (lambda msg: print(msg, file=sys.stderr, flush=True))
        self.out = Path(cfg.out)
        self.last = checkpoint.last_path(self.out)

    # ---- state -------------------------------------------------------------------------------------
    def _remove_stale_temps(self):
        """Delete the temporary files a killed run left beside this run's outputs: this run owns those names."""
        names = {p.name for p in (self.out, self.last, checkpoint.curve_path(self.out))}
        files.sweep(self.out.parent, owned=names.__contains__)

    def _read_resume(self):
        """Rank 0 reads MODEL.last.pt (the other ranks' nodes may not see the file); every rank gets it, or the
        same UserError."""
        got = None
        if self.dist.main:
            try:
                if self.last.is_file():
                    got = ("ok", checkpoint.load(self.last))
                    if "train_state" not in got[1]:
                        raise UserError(f"{self.last}: has no training state to resume from")
            except UserError as e:
                got = ("error", str(e))
        got = self.dist.from_main(got, "the start (reading the resume file)")
        if got and got[0] == "error":
            raise UserError(got[1])
        return got[1] if got else None

    def _setup(self):
        cfg = self.cfg
        self.dist, self.device = distributed.setup(cfg.device)
        if not self.dist.main:
            self.log = lambda msg: None  # rank 0 speaks for the run
        self.dist.note = f" The last good checkpoint {self.last} is kept; continue with --resume (any process count)."
        if self.dist.main:
            self._remove_stale_temps()
        resume = None
        if cfg.resume:
            resume = self._read_resume()
            if resume is not None:
                stored = resume["train_state"]["config"]
                for k in ("variant", "inputs", "arch", "optimizer", "batch", "crop", "crops_per_image", "seed",
                          "val_fraction"):
                    setattr(cfg, k, stored[k])
                cfg.target = stored.get("target") or ch.TARGET_GROUP  # a run before targets learned the image
                for k in ("lr", "clip", "early_stop"):  # given again: the new value wins (e.g. a lower lr)
                    if getattr(cfg, k) is None:
                        setattr(cfg, k, stored[k])
                if cfg.epochs is None and cfg.minutes is None:
                    cfg.epochs, cfg.minutes = stored["epochs"], stored["minutes"]
                was = resume["train_state"].get("world_size", 1)
                self.log(f"resuming from {self.last} at epoch {resume['train_state']['epoch']}, "
                         f"step {resume['train_state']['step']}"
                         + (f" (written by {was} process(es), continued by {self.dist.world})" if was != self.dist.world else ""))
            else:
                self.log(f"--resume: no {self.last} yet, starting a new training")
        if cfg.epochs is None and cfg.minutes is None:
            cfg.minutes = DEFAULT_MINUTES
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        spec = ch.parse_spec(cfg.inputs)
        if self.dataset is None and cfg.cache_mb:
            self.log(f"reading {cfg.data} on demand (cache {cfg.cache_mb:g} MB per process) ...")
            self.dataset = batches.load_lazy(cfg.data, spec, cfg.cache_mb, target=cfg.target)
        if self.dataset is None:
            self.log(f"loading {', '.join(map(str, data_dirs(cfg.data)))} ...")
            self.dataset = data.load_folders(cfg.data, spec, target=cfg.target)
        ds = self.dataset
        if cfg.target is not None and cfg.target != ds.target:
            raise UserError(f"the dataset was loaded for target {ds.target}, training wants {cfg.target}")
        cfg.target = ds.target
        if tuple(ds.spec) != spec:
            raise UserError(f"dataset was loaded for inputs {ch.format_spec(ds.spec)}, training wants {ch.format_spec(spec)}")
        for k, why in ds.skipped.items():
            self.log(f"skipped sample {k}: {why}")
        if ds.repaired:
            self.log(f"repaired {ds.repaired} non-finite input pixel(s) (NaN->0, Inf->65504 / background)")
        ident = ds.identity()
        if resume is not None and resume["dataset"].get("manifest_sha256") != ident["manifest_sha256"]:
            raise UserError(f"{self.last}: was trained on another dataset (the manifest of "
                            f"{', '.join(map(str, data_dirs(cfg.data)))} differs); train without --resume or point "
                            "--data at the original dataset(s), in the same order")
        if self.split is None:
            train_sc, val_sc = ds.split(cfg.val_fraction, cfg.seed)
            self.train_set, self.val_set = ds.subset(train_sc), ds.subset(val_sc)
            split = dict(train=train_sc, val=val_sc, val_fraction=cfg.val_fraction, seed=cfg.seed)
        else:
            tr, va = ({str(k) for k in keys} for keys in self.split)
            self.train_set = [s for s in ds.samples if s.key in tr]
            self.val_set = [s for s in ds.samples if s.key in va]
            train_sc, val_sc = sorted({s.scene for s in self.train_set}), sorted({s.scene for s in self.val_set})
            split = dict(train=[s.key for s in self.train_set], val=[s.key for s in self.val_set], by="view")
        self.identity = dict(ident, split=split)
        mine = {k: v for k, v in asdict(cfg).items() if k not in ("command", "data", "out", "threads", "workers", "cache_mb")}
        distributed.check_same(self.dist, dict(mine, manifest_sha256=ident["manifest_sha256"]), "settings")
        torch.manual_seed(cfg.seed)
        if cfg.init and resume is None and self.init_state is None:
            self.init_state = self._init_from(cfg.init, spec)
        self.net = network.build(network.arch_for(cfg.variant, spec, target=cfg.target, **cfg.arch))
        self.net.train()
        self.net.to(self.device, memory_format=torch.channels_last)  # measured 1.2-1.6x faster steps on this CPU
        self.amp = cfg.amp if cfg.amp != "auto" else ("bf16" if self.device.type == "cuda" else "off")
        if self.device.type == "cuda":
            torch.backends.cudnn.benchmark = True  # fixed crop size: let cuDNN pick its fastest kernels
        lr = cfg.lr if cfg.lr is not None else (ADAM_LR if cfg.optimizer == "adam" else SGD_LR)
        self.base_lr = lr
        self.clip = cfg.clip if cfg.clip is not None else (1.0 if cfg.optimizer == "sgd" else None)
        if cfg.optimizer == "adam":
            self.opt = torch.optim.Adam(self.net.parameters(), lr=lr)
        else:
            self.opt = torch.optim.SGD(self.net.parameters(), lr=lr, momentum=0.9)
        self.gen = torch.Generator().manual_seed(cfg.seed + 1)
        self.sizes = [batches.hw(s) for s in self.train_set]
        hmin = min(h for h, _ in self.sizes)
        wmin = min(w for _, w in self.sizes)
        self.crop = (min(cfg.crop, hmin), min(cfg.crop, wmin))
        area = np.mean([h * w for h, w in self.sizes])
        self.cpi = cfg.crops_per_image or max(1, int(round(area / (self.crop[0] * self.crop[1]))))
        self.step = self.epoch = 0
        self.elapsed = 0.0
        self.cpu_before = 0.0  # process CPU seconds of earlier (resumed) runs
        self.history: list[dict] = []
        self.best: dict = {}
        self.lr_scale = 1.0
        self.lr_drops = self.skipped = 0
        self.quarantine: list[str] = []
        if resume is not None:
            self.net.load_state_dict(resume["state_dict"])
            ts = resume["train_state"]
            self.opt.load_state_dict(ts["optimizer"])
            self.gen.set_state(ts["generator"])
            torch.set_rng_state(ts["torch_rng"])
            self.step, self.epoch, self.elapsed = ts["step"], ts["epoch"], ts["elapsed"]
            self.cpu_before = ts.get("cpu_s", 0.0)
            self.lr_scale, self.lr_drops, self.skipped = ts["lr_scale"], ts["lr_drops"], ts["skipped"]
            self.quarantine = list(ts["quarantine"])
            self.history = list(resume["history"])
            self.best = dict(ts["best"])
        if self.init_state is not None:
            self.net.load_state_dict(self.init_state)
        self.model = self.net
        if self.dist.active:  # gradients averaged over the ranks; rank 0's weights broadcast at the start
            self.model = torch.nn.parallel.DistributedDataParallel(
                self.net, device_ids=[self.device.index] if self.device.type == "cuda" else None)
        self.loader = batches.Loader(batches.Crops(self.train_set, self.dataset.spec, self.crop), cfg.workers,
                                     pin=self.device.type == "cuda")
        self.log(f"{self.dist.world} process(es), device {self.device}, mixed precision {self.amp}, "
                 f"global batch {cfg.batch} crops" + (f", {cfg.workers} loader worker(s)" if cfg.workers else ""))
        self.log(f"{cfg.variant}: {network.count_params(self.net):,} parameters, receptive field "
                 f"{self.net.receptive_field}px; {len(self.train_set)} train / {len(self.val_set)} val samples "
                 f"({len(train_sc)} / {len(val_sc)} scenes); {self.cpi} crops of {self.crop[0]}x{self.crop[1]} per image")
        self._snapshot()

    def _init_from(self, path, spec) -> dict:
        """``--init``: the weights of checkpoint ``path`` for this run's inputs (ablation.grow_inputs: its inputs
        kept, new ones at 0); its variant and architecture become this run's."""
        from .ablation import grow_inputs

        ck = checkpoint.load(path)
        old = checkpoint.build_net(ck, path)
        arch = dict(old.arch)
        if arch.get("backbone") == "linear":
            raise UserError(f"--init {path}: a linear baseline cannot start a network's training")
        self.cfg.variant = arch["variant"]
        keys = network.BACKBONES[arch["backbone"]][1]
        self.cfg.arch = {k: arch[k] for k in keys if k in arch and arch[k] != network.VARIANTS[arch["variant"]].get(k)}
        net = grow_inputs(old, spec, target=self.cfg.target)
        self.log(f"--init {path}: its {arch['variant']} weights, inputs {ch.format_spec(tuple(old.arch['inputs']))} "
                 f"grown to {ch.format_spec(spec)} (new inputs' weights 0), target {self.cfg.target}")
        return net.state_dict()

    def _snapshot(self):
        self.snap = (copy.deepcopy(self.net.state_dict()), copy.deepcopy(self.opt.state_dict()))

    def _restore(self):
        self.net.load_state_dict(self.snap[0])
        self.opt.load_state_dict(self.snap[1])

    def _train_state(self) -> dict:
        return dict(config=asdict(self.cfg), optimizer=self.opt.state_dict(), generator=self.gen.get_state(),
                    torch_rng=torch.get_rng_state(), step=self.step, epoch=self.epoch, elapsed=self.elapsed,
                    cpu_s=self._cpu_s(), world_size=self.dist.world,
                    lr_scale=self.lr_scale, lr_drops=self.lr_drops, skipped=self.skipped, best=dict(self.best),
                    quarantine=list(self.quarantine))

    def _cpu_s(self) -> float:
        """CPU seconds of training so far (all threads of this process; a fairer clock than wall time on a
        shared machine)."""
        return self.cpu_before + time.process_time() - self.cpu0

    def _progress(self, epoch_frac: float) -> float:
        p = 0.0
        if self.cfg.epochs:
            p = max(p, epoch_frac / self.cfg.epochs)
        if self.cfg.minutes:
            p = max(p, self.elapsed / (60.0 * self.cfg.minutes))
        return min(1.0, p)

    def _lr(self, progress: float) -> float:
        return self.base_lr * self.lr_scale * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * progress)))

    # ---- batches -----------------------------------------------------------------------------------
    def _local(self, built):
        """This rank's built crops without the quarantined samples: (x, y, mask, used sample indices)."""
        x, y, m, idx = built
        keep = [k for k, i in enumerate(idx) if self.train_set[i].key not in self.quarantine]
        if len(keep) < len(idx):
            if not keep:
                return None, None, None, []
            x, y, m = x[keep], y[keep], m[keep]
        return x, y, m, [idx[k] for k in keep]

    def _bad_step(self, why: str):
        self.skipped += 1
        self.bad_streak += 1
        self.opt.zero_grad(set_to_none=True)
        if self.skipped <= 20:
            self.log(f"step {self.step}: {why}; step skipped" + (" (further skips are not logged)" if self.skipped == 20 else ""))
        if self.bad_streak >= BAD_STREAK:
            self.bad_streak = 0
            self.lr_drops += 1
            if self.lr_drops > MAX_LR_DROPS:
                raise Diverged(f"training diverged: {why} persisted after halving the learning rate {MAX_LR_DROPS} "
                               f"times (now {self._lr(0):.3g}); stopped. The last good checkpoint {self.out} is kept. "
                               "Try a lower --lr or check the dataset.")
            self._restore()
            self.lr_scale *= 0.5
            self.log(f"step {self.step}: {why} {BAD_STREAK} times in a row; back to the last good weights, "
                     f"learning rate halved (x{self.lr_scale:g})")

    def _train_step(self, x, y, m, lr, used=()) -> float | None:
        """One step on this rank's crops; under torchrun the loss is normalised by the pixel count of the global
        batch (so DDP's mean of the ranks' gradients is the gradient of one process over the global batch), and
        every decision (skip, quarantine, restore) is taken from global values, the same on every rank."""
        if not self.dist.active and not used:
            return None
        if not used:  # a rank whose share is empty (all left out) still takes part: zero crops, zero weight
            x = torch.zeros((1, network.in_channels(self.net)) + self.crop).contiguous(memory_format=torch.channels_last)
            y = torch.zeros((1, 3) + self.crop)
            m = torch.zeros((1, 1) + self.crop)
        for g in self.opt.param_groups:
            g["lr"] = lr
        dev = self.device
        x, y, m = (t.to(dev, non_blocking=True) for t in (x, y, m))
        with torch.autocast(dev.type, dtype=torch.bfloat16, enabled=self.amp == "bf16"):
            out = self.model(x)
        sq = (((out.float() - normalize.light_forward(y)) ** 2) * m).sum()
        if self.dist.active:
            tot = self.dist.sum_(torch.stack([sq.detach(), m.sum(), torch.tensor(float(len(used)), device=dev)])
                                 .to(self.dist.device))
            if float(tot[2]) == 0:
                return None
            denom = (3 * tot[1]).clamp_min(1.0)
            loss = sq * self.dist.world / denom.to(dev)
            lv = float(tot[0] / denom)
        else:
            loss = sq / (3 * m.sum()).clamp_min(1.0)
            lv = float(loss.detach())
        if not math.isfinite(lv):
            mine = [self.train_set[i].key for k, i in enumerate(used)
                    if not (torch.isfinite(x[k]).all() and torch.isfinite(y[k]).all())]
            bad = [k for keys in self.dist.gather(mine, "the data check") for k in keys]
            if bad:  # a data fault, not a training fault: leave the sample out from now on
                by_key = {s.key: s for s in self.train_set}
                for key in bad:
                    if key not in self.quarantine:
                        self.quarantine.append(key)
                        self.log(f"step {self.step}: sample {key} (scene {by_key[key].scene}) holds non-finite values; "
                                 "left out of training from now on")
                self.opt.zero_grad(set_to_none=True)
                self.skipped += 1
                return None
            self._bad_step("non-finite loss")
            return None
        if self.loss_ema is not None and lv > EXPLODE * max(self.loss_ema, 1e-4):
            self._bad_step(f"exploding loss ({lv:.3g} vs running mean {self.loss_ema:.3g})")
            return None
        self.good_losses += 1
        if self.good_losses % SNAPSHOT_EVERY == 0:  # weights that just gave a sane loss
            self._snapshot()
        self.opt.zero_grad(set_to_none=True)
        self.dist.backward(loss)
        gn = torch.nn.utils.clip_grad_norm_(self.net.parameters(), self.clip if self.clip else float("inf"))
        if not torch.isfinite(gn):
            self._bad_step("non-finite gradient")
            return None
        self.opt.step()
        if not all(torch.isfinite(p).all() for p in self.net.parameters()):
            self._restore()
            self._bad_step("non-finite weights")
            return None
        self.bad_streak = 0
        self.loss_ema = lv if self.loss_ema is None else 0.95 * self.loss_ema + 0.05 * lv
        self.step += 1
        return lv

    # ---- the loop ----------------------------------------------------------------------------------
    def run(self, callback=None, should_stop=None) -> dict:
        cb = callback or (lambda d: None)
        stop = should_stop or (lambda: False)
        self.cpu0 = time.process_time()
        self._setup()
        self.cpu0 = time.process_time()  # data loading does not count
        if not self.dist.main:
            cb = lambda d: None  # noqa: E731 (rank 0 reports)
        cfg = self.cfg
        self.bad_streak = self.good_losses = 0
        self.loss_ema = None
        status, t_last_cb = "done", 0.0
        since_best = 0
        if self.history and self.best:
            since_best = self.history[-1]["epoch"] - self.best["epoch"]
        while True:
            if cfg.epochs is not None and self.epoch >= cfg.epochs:
                break
            if cfg.minutes is not None and self.elapsed >= 60 * cfg.minutes:
                break
            if cfg.early_stop and since_best >= cfg.early_stop:
                self.log(f"early stop: no validation improvement for {since_best} epochs")
                status = "early-stopped"
                break
            plan = batches.plan(self.gen, self.sizes, self.cpi, cfg.batch, self.crop)
            nb = len(plan)
            built = self.loader.epoch(batches.share(plan, self.dist.rank, self.dist.world))
            losses = []
            t0 = time.perf_counter()
            el0 = self.elapsed
            partial = False
            for b in range(nb):
                cancel = stop()
                self.elapsed = el0 + time.perf_counter() - t0
                over = cfg.minutes is not None and self.elapsed >= 60 * cfg.minutes
                if self.dist.active:  # every rank breaks at the same batch
                    flags = torch.tensor([float(cancel), float(over)], device=self.dist.device)
                    cancel, over = (bool(v > 0) for v in self.dist.sum_(flags, "the stop check of a step"))
                if cancel:
                    status = "cancelled"
                    break
                if over:
                    partial = True
                    break
                prog = self._progress(self.epoch + b / nb)
                x, y, m, used = self._local(next(built))
                lv = self._train_step(x, y, m, self._lr(prog), used)
                if lv is not None:
                    losses.append(lv)
                now = time.perf_counter()
                if now - t_last_cb > 0.5:
                    t_last_cb = now
                    cb(self._state("batch", prog, np.mean(losses[-20:]) if losses else math.nan, batch=b + 1, batches=nb))
            if status == "cancelled":
                self.log(f"cancelled at epoch {self.epoch + 1}, step {self.step}; the last checkpoint is kept")
                break
            self.elapsed = el0 + time.perf_counter() - t0
            self.epoch += 1
            # validation once, on rank 0, of the plain module: what one process computes on these weights
            ev, self.elapsed = self.dist.from_main((evaluate(self.net, self.val_set) if self.dist.main else None,
                                                    self.elapsed), f"the validation of epoch {self.epoch}")
            if not math.isfinite(ev["val_loss"]):
                self._restore()
                raise Diverged(f"validation loss is not finite at epoch {self.epoch}; stopped, {self.out} is kept")
            entry = dict(epoch=self.epoch, step=self.step, minutes=self.elapsed / 60.0, cpu_minutes=self._cpu_s() / 60.0,
                         loss=float(np.mean(losses)) if losses else math.nan, lr=self._lr(self._progress(self.epoch)),
                         skipped=self.skipped, partial=partial, **ev)
            self.history.append(entry)
            # the best by val_score: the mean of the folders' PSNRs (validation.evaluate; one folder: val_psnr)
            improved = not self.best or ev["val_score"] > self.best.get("val_score", self.best["val_psnr"])
            if improved:
                self.best = dict(entry)
                since_best = 0
            else:
                since_best += 1
            if self.dist.main:
                self._save(improved)
            self.dist.note = (f" The last good checkpoint {self.last} (epoch {self.epoch}) is kept; continue with "
                              "--resume (any process count).")
            self.log(f"epoch {self.epoch}: loss {entry['loss']:.5f}  val PSNR {ev['val_psnr']:.2f} dB "
                     f"(tm {ev['val_tm_psnr']:.2f}, SSIM {ev['val_ssim']:.3f})  {self.elapsed / 60:.2f} min"
                     + ("  folders " + ", ".join(f"{t} {v:.2f}" for t, v in ev["val_folders"].items())
                        + f" (mean {ev['val_score']:.2f})" if "val_folders" in ev else "")
                     + ("  *best" if improved else ""))
            cb(self._state("epoch", self._progress(self.epoch), entry["loss"]))
        self.dist.close()
        if self.history and self.dist.main:
            curves.curve_png(self.history, checkpoint.curve_path(self.out), f"{cfg.variant} on {' + '.join(Path(d).name for d in data_dirs(cfg.data))}")
        summary = dict(status=status, model=str(self.out), last=str(self.last), epochs=self.epoch, step=self.step,
                       minutes=self.elapsed / 60, best=self.best, skipped_steps=self.skipped, lr_drops=self.lr_drops,
                       params=network.count_params(self.net), variant=cfg.variant, left_out=list(self.quarantine),
                       curve=str(checkpoint.curve_path(self.out)) if self.history else None,
                       world_size=self.dist.world, rank=self.dist.rank, device=str(self.device), amp=self.amp)
        cb(dict(self._state("end", 1.0, math.nan), status=status))
        return summary

    def _state(self, event, progress, loss, **kw) -> dict:
        eta = None
        if progress > 0:
            eta = max(0.0, self.elapsed * (1 - progress) / progress)
        return dict(event=event, epoch=self.epoch, epochs=self.cfg.epochs, step=self.step, loss=float(loss),
                    val_psnr=self.history[-1]["val_psnr"] if self.history else None,
                    best_psnr=self.best.get("val_psnr"), elapsed_s=self.elapsed, eta_s=eta, progress=progress, **kw)

    def _save(self, improved: bool):
        kw = dict(history=self.history, best=self.best, dataset=self.identity, command=self.cfg.command)
        checkpoint.save(self.last, checkpoint.make(self.net, "network", train_state=self._train_state(), **kw))
        if improved:
            checkpoint.save(self.out, checkpoint.make(self.net, "network", **kw))
