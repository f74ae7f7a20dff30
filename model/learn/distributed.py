"""The Trainer's processes under ``torchrun`` (bpy-free): device choice, the process group, and the few collectives
training needs, each turning a lost peer into one clear ``UserError``.

``torchrun --nproc_per_node N cli.py train ...`` starts N processes with ``RANK``, ``LOCAL_RANK``,
``WORLD_SIZE``, ``MASTER_ADDR``/``MASTER_PORT`` set; ``setup`` joins them (gloo on CPU, NCCL on CUDA, one GPU per
local rank). Without ``WORLD_SIZE`` (or with 1) nothing is started and every collective is the identity, so a
single-process run executes exactly the code it did before.

What goes over the wire (see train.py): per step the loss numerator and pixel count (the loss is normalised by
the *global* pixel count, so the averaged gradients are those of one process over the whole global batch), the
gradients (DistributedDataParallel), one stop flag (time budget / cancel, so that every rank breaks at the same
batch); per epoch rank 0's validation result; at start rank 0's resume state and every rank's settings and
dataset identity (a rank started with other settings or another dataset is refused).
"""
from __future__ import annotations

import datetime
import os
import re
import signal
import threading
from dataclasses import dataclass, field

import torch

from ..errors import UserError

TIMEOUT = datetime.timedelta(minutes=float(os.environ.get("SSGI_DIST_TIMEOUT_MIN", "30")))


class LostRank(UserError):
    """A collective failed: another process of the run died or hung."""


def pick_device(want: str = "auto", local_rank: int = 0) -> torch.device:
    """``auto``: CUDA (GPU ``local_rank``) when present, else CPU; ``cpu``; ``cuda`` (a UserError without one)."""
    if want not in ("auto", "cpu", "cuda"):
        raise UserError(f"--device must be auto, cpu or cuda, not {want!r}")
    if want == "cpu" or (want == "auto" and not torch.cuda.is_available()):
        return torch.device("cpu")
    if not torch.cuda.is_available():
        raise UserError("--device cuda: torch sees no CUDA device (torch.cuda.is_available() is False)")
    n = torch.cuda.device_count()
    if local_rank >= n:
        raise UserError(f"local rank {local_rank} has no GPU of its own: this node has {n}; start at most {n} "
                        f"processes per node (torchrun --nproc_per_node {n})")
    return torch.device("cuda", local_rank)


def _first_sentence(e: Exception) -> str:
    """The gist of a backend error: gloo's "[/path/pair.cc:537] Read error [127.0.0.1]:38296: Connection reset by
    peer. This is typically caused by ..." -> "Read error [127.0.0.1]:38296: Connection reset by peer"."""
    text = (str(e).strip().splitlines() or [type(e).__name__])[0]
    text = re.sub(r"^\[[^\]]*\]\s*", "", text)
    return text.split(". ")[0][:200]


@dataclass
class Dist:
    rank: int = 0
    world: int = 1
    local_rank: int = 0
    note: str = ""  # appended to a LostRank message (the last good checkpoint)
    group: object = field(default=None, repr=False)

    @property
    def active(self) -> bool:
        return self.world > 1

    @property
    def main(self) -> bool:
        return self.rank == 0

    def _fail(self, what: str, e: Exception):
        first = _first_sentence(e)
        raise LostRank(f"rank {self.rank} of {self.world}: lost contact with the other processes during {what} "
                       f"(another rank died or hung: {first}); stopped.{self.note}") from None

    COMM_WORDS = ("gloo", "nccl", "connection", "closed", "timed out", "timeout", "peer", "socket")

    def backward(self, loss: torch.Tensor) -> None:
        """``loss.backward()``; under DDP the gradient exchange runs inside it, so a lost peer surfaces here."""
        try:
            loss.backward()
        except RuntimeError as e:
            if self.active and (isinstance(e, getattr(torch.distributed, "DistError", ()))
                                or any(w in str(e).lower() for w in self.COMM_WORDS)):
                self._fail("the gradient exchange", e)
            raise

    def sum_(self, t: torch.Tensor, what: str = "the loss exchange of a step") -> torch.Tensor:
        """All-reduce ``t`` (sum) in place; the identity in one process."""
        if self.active:
            try:
                torch.distributed.all_reduce(t)
            except (RuntimeError, ValueError) as e:
                self._fail(what, e)
        return t

    def gather(self, obj, what: str) -> list:
        """Every rank's ``obj`` (picklable), in rank order; ``[obj]`` in one process."""
        if not self.active:
            return [obj]
        out = [None] * self.world
        try:
            torch.distributed.all_gather_object(out, obj)
        except (RuntimeError, ValueError) as e:
            self._fail(what, e)
        return out

    def from_main(self, obj, what: str):
        """Rank 0's ``obj`` on every rank."""
        if not self.active:
            return obj
        box = [obj]
        try:
            torch.distributed.broadcast_object_list(box, src=0)
        except (RuntimeError, ValueError) as e:
            self._fail(what, e)
        return box[0]

    def close(self):
        if self.active and torch.distributed.is_initialized():
            torch.distributed.destroy_process_group()


def setup(device_wanted: str = "auto") -> tuple[Dist, torch.device]:
    """Join the torchrun processes (if any) and pick this process's device."""
    world = int(os.environ.get("WORLD_SIZE", "1") or 1)
    if world <= 1:
        d = Dist()
        d.device = pick_device(device_wanted)
        return d, d.device
    missing = [k for k in ("RANK", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT") if k not in os.environ]
    if missing:
        raise UserError(f"WORLD_SIZE={world} but {', '.join(missing)} not set: start distributed training with "
                        f"torchrun (torchrun --nproc_per_node {world} cli.py train ...), not by hand")
    rank, local = int(os.environ["RANK"]), int(os.environ["LOCAL_RANK"])
    device = pick_device(device_wanted, local)
    backend = "nccl" if device.type == "cuda" else "gloo"
    if device.type == "cuda":
        torch.cuda.set_device(device)
    try:
        torch.distributed.init_process_group(backend, rank=rank, world_size=world, timeout=TIMEOUT)
    except (RuntimeError, ValueError) as e:
        first = _first_sentence(e)
        raise UserError(f"rank {rank} of {world}: could not join the other processes ({backend} at "
                        f"{os.environ['MASTER_ADDR']}:{os.environ['MASTER_PORT']}: {first})") from None
    d = Dist(rank=rank, world=world, local_rank=local)
    d.device = device if backend == "nccl" else torch.device("cpu")  # where small collective tensors live
    if threading.current_thread() is threading.main_thread():
        def on_term(signum, frame):  # torchrun ends the other ranks with SIGTERM when one fails
            signal.signal(signum, signal.SIG_DFL)
            raise LostRank(f"rank {d.rank} of {d.world}: stopped by the launcher (signal {signum}; another process "
                           f"of this run ended, see torchrun's report).{d.note}")
        signal.signal(signal.SIGTERM, on_term)
    return d, device


def check_same(dist: Dist, mine: dict, what: str) -> None:
    """Refuse a run whose ranks disagree on ``mine`` (settings, dataset identity): name the first difference."""
    if not dist.active:
        return
    for r, theirs in enumerate(dist.gather(mine, f"the check of the ranks' {what}")):
        for k in sorted(set(mine) | set(theirs)):
            if theirs.get(k) != mine.get(k):
                raise UserError(f"rank {r} of {dist.world} was started with other {what} than rank {dist.rank} ({k}: "
                                f"{theirs.get(k)!r} vs {mine.get(k)!r}); start every process with the same command "
                                f"and the same dataset")
