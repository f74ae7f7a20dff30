"""What a report run records besides its numbers, and the record as JSON (bpy-free): the date, the machine and
the library versions; ``write_json`` writes the raw record (inf and nan as strings: JSON has neither)."""
from __future__ import annotations

import datetime
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np

from .. import files


def json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    return str(o)


def finite_or_str(o):
    """JSON has no inf/nan: write them as strings "inf", "-inf", "nan"."""
    if isinstance(o, float) and not math.isfinite(o):
        return "nan" if math.isnan(o) else ("inf" if o > 0 else "-inf")
    if isinstance(o, dict):
        return {k: finite_or_str(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [finite_or_str(v) for v in o]
    return o


def write_json(path, raw: dict) -> Path:
    return files.write_json(path, finite_or_str(raw), indent=1, default=json_default, allow_nan=False)


def machine() -> dict:
    """What ran the report: CPU, cores, memory, load, OS."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem = round(int(line.split()[1]) / 2 ** 20, 1)
    except OSError:
        pass
    return dict(cpu=cpu, cores=os.cpu_count(), memory_gib=mem, os=platform.platform(),
                python=sys.version.split()[0], loadavg_start=list(os.getloadavg()) if hasattr(os, "getloadavg") else None)


def versions() -> dict:
    out = dict(python=sys.version.split()[0], numpy=np.__version__)
    for mod in ("torch", "flip_evaluator", "skimage", "OpenEXR", "matplotlib"):
        try:
            m = __import__(mod)
            out[mod] = str(getattr(m, "__version__", "")) or _dist_version(mod)
        except ImportError:
            out[mod] = None
    return out


def _dist_version(mod: str) -> str:
    from importlib import metadata
    for name in (mod, mod.replace("_", "-"), mod.lower()):
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return "?"



def now() -> str:
    return datetime.datetime.now().isoformat(timespec="seconds")
