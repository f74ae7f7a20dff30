"""argparse type functions shared by every subcommand (bpy-free).

Use them as ``type=`` of ``add_argument``; a bad value makes argparse exit with status 2 and a message that
names the argument and says what is wrong, e.g.::

    cli.py bake: error: argument --size: '64by36' is not WIDTHxHEIGHT (e.g. 240x135)

They raise ``ArgError``, which is both an ``argparse.ArgumentTypeError`` (argparse shows its message) and a
``UserError`` (operators and other callers can catch it like any user-fixable error).

    parse_size("240x135")  -> Size(width=240, height=135)
    parse_frames("1-4,10") -> (1, 2, 3, 4, 10)
    parse_shard("0/4")     -> Shard(index=0, count=4);  Shard.take(items) -> items[0::4]
    working_res("4x")      -> "4x" (checked by model/infer/workres.parse_setting)
"""
from __future__ import annotations

import argparse
import codecs
import re
from pathlib import Path
from typing import NamedTuple, Sequence

from .errors import UserError

MAX_SIZE = 16384  # Blender's own largest render resolution per side
MAX_FRAMES = 1_000_000


class ArgError(argparse.ArgumentTypeError, UserError):
    """A bad command-line value: argparse prints the message after ``argument --name:``."""


class Size(NamedTuple):
    width: int
    height: int

    def __str__(self) -> str:
        return f"{self.width}x{self.height}"


class Shard(NamedTuple):
    """Shard ``index`` of ``count`` (0-based): this worker takes every ``count``-th item from ``index``."""
    index: int
    count: int

    def take(self, items: Sequence):
        return items[self.index::self.count]

    def owns(self, i: int) -> bool:
        return i % self.count == self.index

    def __str__(self) -> str:
        return f"{self.index}/{self.count}"


def _int(text: str, what: str) -> int:
    t = str(text).strip()
    if not re.fullmatch(r"[+-]?\d+", t):
        raise ArgError(f"{text!r} is not an integer ({what})")
    return int(t)


def _two_ints(text: str, sep: str, form: str) -> tuple[int, int]:
    m = re.fullmatch(rf"\s*(\d+)\s*{sep}\s*(\d+)\s*", str(text))
    if not m:
        raise ArgError(f"{text!r} is not {form}")
    return int(m.group(1)), int(m.group(2))


def parse_size(text: str) -> Size:
    """``"WIDTHxHEIGHT"`` -> Size; each side 1..16384."""
    w, h = _two_ints(text, "[xX]", "WIDTHxHEIGHT (e.g. 240x135)")
    for side, v in (("width", w), ("height", h)):
        if not 1 <= v <= MAX_SIZE:
            raise ArgError(f"{text!r}: {side} {v} is out of range 1..{MAX_SIZE}")
    return Size(w, h)


def working_res(text: str) -> str:
    """``auto`` | ``full`` | ``Nx`` | ``WxH``: the resolution the network predicts at (model/infer/workres.py);
    returned as given once it parses."""
    from .infer.workres import parse_setting
    try:
        parse_setting(text)
    except UserError as e:
        raise ArgError(str(e)) from None
    return str(text)


def parse_frames(text: str) -> tuple[int, ...]:
    """``"A-B"`` (inclusive), ``"N"``, or a comma list of those (``"1-3,7"``) -> tuple of frame numbers, in
    the order given. A frame named twice or a range running backwards is an error."""
    items = [s.strip() for s in str(text).split(",")]
    if not text or any(s == "" for s in items):
        raise ArgError(f"{text!r} is not a frame list like 1-10 or 1,5,9-12 (empty item)")
    out: list[int] = []
    for s in items:
        m = re.fullmatch(r"(-?\d+)(?:\s*-\s*(-?\d+))?", s)
        if not m:
            raise ArgError(f"{text!r}: {s!r} is not a frame number or a range A-B")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise ArgError(f"{text!r}: range {s!r} runs backwards ({a} > {b})")
        if len(out) + (b - a + 1) > MAX_FRAMES:
            raise ArgError(f"{text!r}: more than {MAX_FRAMES} frames")
        out.extend(range(a, b + 1))
    if len(set(out)) != len(out):
        dup = sorted({f for f in out if out.count(f) > 1})
        raise ArgError(f"{text!r}: frame(s) {', '.join(map(str, dup[:5]))} named twice")
    return tuple(out)


def parse_shard(text: str) -> Shard:
    """``"i/n"`` -> Shard(i, n), 0-based: ``0/4`` .. ``3/4`` split the work into 4 disjoint parts."""
    i, n = _two_ints(text, "/", "INDEX/COUNT (e.g. 0/4; the index is 0-based)")
    if n < 1:
        raise ArgError(f"{text!r}: the shard count must be at least 1")
    if i >= n:
        raise ArgError(f"{text!r}: shard index {i} must be below the count {n} (indices are 0-based: 0..{n - 1})")
    return Shard(i, n)


def positive_int(text: str) -> int:
    v = _int(text, "expected a whole number >= 1")
    if v < 1:
        raise ArgError(f"{text!r} must be >= 1")
    return v


def nonnegative_int(text: str) -> int:
    v = _int(text, "expected a whole number >= 0")
    if v < 0:
        raise ArgError(f"{text!r} must be >= 0")
    return v


def _float(text: str) -> float:
    try:
        v = float(str(text).strip())
    except ValueError:
        raise ArgError(f"{text!r} is not a number") from None
    if v != v or v in (float("inf"), float("-inf")):
        raise ArgError(f"{text!r} is not a finite number")
    return v


def positive_float(text: str) -> float:
    v = _float(text)
    if v <= 0:
        raise ArgError(f"{text!r} must be > 0")
    return v


def nonnegative_float(text: str) -> float:
    v = _float(text)
    if v < 0:
        raise ArgError(f"{text!r} must be >= 0")
    return v


def unit_float(text: str) -> float:
    """A number in [0, 1]."""
    v = _float(text)
    if not 0.0 <= v <= 1.0:
        raise ArgError(f"{text!r} must be between 0 and 1")
    return v


def existing_file(text: str) -> Path:
    p = Path(text).expanduser()
    if not p.is_file():
        raise ArgError(f"{text!r}: no such file" + (" (it is a folder)" if p.is_dir() else ""))
    return p


def model_arg(text: str) -> str:
    """A ``--model`` value: a shipped model's name (model/shipped.py: "default", "one_render") becomes its file; any
    other value is a path, kept as given."""
    from . import shipped
    p = shipped.resolve(text) if text.strip() in shipped.BY_NAME else None
    return str(p) if p is not None else text


def existing_model(text: str) -> Path:
    """``model_arg``, then ``existing_file``."""
    return existing_file(model_arg(text))


MODEL_HELP = "a shipped model's name (default, one_render) or a checkpoint file"


def existing_dir(text: str) -> Path:
    p = Path(text).expanduser()
    if not p.is_dir():
        raise ArgError(f"{text!r}: no such folder" + (" (it is a file)" if p.exists() else ""))
    return p


def channel_spec(text: str) -> tuple[str, ...]:
    """An input channel spec ``"albedo,normal,depth,direct,lit"`` checked against model/channels.py."""
    from . import channels
    try:
        return channels.parse_spec(text)
    except ArgError:
        raise
    except UserError as e:
        raise ArgError(str(e)) from None


# the first bytes of files that are often passed as a model by mistake
_NOT_MODELS = ((b"\x89PNG", "a PNG image"), (b"\xff\xd8\xff", "a JPEG image"), (b"v/1\x01", "an OpenEXR image"),
               (b"GIF8", "a GIF image"), (b"II*\x00", "a TIFF image"), (b"MM\x00*", "a TIFF image"),
               (b"BLENDER", "a .blend file"), (b"\x28\xb5\x2f\xfd", "zstd-compressed data, as a compressed .blend"),
               (b"\x1f\x8b", "a gzip-compressed file"), (b"%PDF", "a PDF document"))
_A_MODEL = "a model is one .pt file written by `cli.py train`, `baseline` or `fit`"


def model_file_fault(path) -> str | None:
    """Why ``path`` cannot be an SSGI model, told without torch: "no such model file", or "not an SSGI model
    checkpoint (what it is ...)" for a folder, an empty, text or image file; None when it may be one (a torch
    file: zip, or a pickle from before torch 1.6), for the loader to decide."""
    p = Path(path).expanduser()
    if p.is_dir():
        return f"not an SSGI model checkpoint (a folder; {_A_MODEL})"
    if not p.is_file():
        return "no such model file"
    with p.open("rb") as f:
        head = f.read(512)
    what = None
    if not head:
        what = "an empty file"
    elif not (head.startswith(b"PK\x03\x04") or head[:1] == b"\x80"):
        what = next((w for magic, w in _NOT_MODELS if head.startswith(magic)), None)
        if what is None:
            try:  # incremental: a character cut at byte 512 is no fault
                text = codecs.getincrementaldecoder("utf-8")().decode(head)
                if "\x00" not in text:
                    what = f"a text file: {' '.join(text.split())[:60]!r}"
            except UnicodeDecodeError:
                pass
    return f"not an SSGI model checkpoint ({what}; {_A_MODEL})" if what else None
