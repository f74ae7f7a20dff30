"""Files written whole or not at all, and the temporary files a killed writer leaves (bpy-free).

One pattern for every temporary file SSGI writes: ``.FINAL_NAME.PID.tmp`` beside the final file (``temp_path``),
e.g. ``.000042.exr.1234.tmp`` or ``.model.pt.1234.tmp``. A writer writes the temporary file and renames it
onto the final name when complete (``atomic_write``; ``write_text``/``write_json`` for text), so a killed
writer never leaves a half-written file under a final name, only a temporary one, which ``sweep`` removes.
Writers that pick the format from the file name (PIL, matplotlib, Blender) are told the format explicitly.

Scratch files that are no atomic write (a render saved only to be read back, ``scratch``) follow the same
pattern with a unique final name, so the same ``sweep`` removes what a killed process left of them.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
import time
from pathlib import Path

TEMP_RE = re.compile(r"^\.(?P<final>.+)\.(?P<pid>\d+)\.tmp$")
# Temporary names of the code before the one pattern, still swept so that a folder a killed older run left
# behind is cleaned too: render frames ``.STEM.PID.tmp.EXT`` (final STEM.EXT) and learning curves
# ``.NAME.tmp.png`` (final NAME, no pid).
LEGACY_TEMP_RES = (re.compile(r"^\.(?P<stem>.+)\.(?P<pid>\d+)\.tmp(?P<ext>\.[A-Za-z0-9]+)$"),
                   re.compile(r"^\.(?P<final>.+\.png)\.tmp\.png$"))


def _temp_match(name: str) -> tuple[str, int | None] | None:
    """(final name, writer's pid or None) of a temporary file's name, or None for any other name."""
    m = TEMP_RE.match(name)
    if m:
        return m.group("final"), int(m.group("pid"))
    m = LEGACY_TEMP_RES[0].match(name)
    if m:
        return m.group("stem") + m.group("ext"), int(m.group("pid"))
    m = LEGACY_TEMP_RES[1].match(name)
    if m:
        return m.group("final"), None
    return None


def temp_path(path) -> Path:
    """The temporary name ``path`` is written under before it is renamed onto ``path``."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def atomic_write(path, write) -> Path:
    """Call ``write(tmp_path)``, then rename the temporary file onto ``path``; on any error the temporary
    file is removed and the old ``path`` (if any) stays. Returns ``path``."""
    path = Path(path)
    tmp = temp_path(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def write_text(path, text: str) -> Path:
    return atomic_write(path, lambda p: Path(p).write_text(text))


def write_json(path, obj, **dumps) -> Path:
    """``json.dumps(obj, **dumps)`` written atomically (``indent=1`` unless given)."""
    dumps.setdefault("indent", 1)
    return write_text(path, json.dumps(obj, **dumps))


def scratch(stem: str, suffix: str = "", folder=None) -> Path:
    """Create a new empty scratch file with a unique name in ``folder`` (default: the system temporary
    folder), named by the temporary-file pattern (final name ``STEM-RANDOM SUFFIX``). The caller deletes it."""
    fd, name = tempfile.mkstemp(dir=folder, prefix=f".{stem}-", suffix=f"{suffix}.{os.getpid()}.tmp")
    os.close(fd)
    return Path(name)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # someone else's process (or not a pid): leave its files alone
    return True


def sweep(folder, owned=None, min_age_s: float | None = None) -> list[str]:
    """Delete the temporary files (``TEMP_RE``, and the older ``LEGACY_TEMP_RES``) in ``folder``; never a final
    name. Returns the names removed.

    ``owned(final_name) -> bool`` limits this to the files of one job (a shard's samples and manifest), so
    that a job (re)started beside a running one never deletes the other's file in flight. With ``min_age_s``
    (a folder shared with live processes, such as the system temporary folder) a file is removed only when
    the process that wrote it is gone and the file is at least that old (a process in another pid namespace
    sharing the folder cannot lose a file in use); without it every matching file is removed (the caller
    owns the folder's final names, and its own temporary files are not in flight)."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    removed = []
    now = time.time()
    for p in folder.iterdir():
        m = _temp_match(p.name)
        if m is None or (owned is not None and not owned(m[0])):
            continue
        if min_age_s is not None:
            pid = m[1]
            if pid is None or pid == os.getpid() or _alive(pid):
                continue
            with contextlib.suppress(OSError):
                if now - p.stat().st_mtime < min_age_s:
                    continue
        with contextlib.suppress(FileNotFoundError):
            if p.is_file():
                p.unlink()
                removed.append(p.name)
    return removed
