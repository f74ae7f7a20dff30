"""The progress protocol between a child process and the job that watches it (bpy-free).

A command run with ``--progress`` writes one line per report on stderr: ``SSGI_PROGRESS {json object}``.
The object holds at least ``progress`` (0..1) and may hold ``phase``, ``message``, ``eta_s`` (seconds left) and
anything else the stage reports: the keys a job's state shares (runtime/jobs.py). Every other stderr line is
log text. ``emit`` writes such a line, ``parse`` reads one back (None for a log line); runtime/launcher.py
reads them from a child.
"""
from __future__ import annotations

import json
import sys

PREFIX = "SSGI_PROGRESS "


def emit(**state) -> None:
    """Write one progress line on stderr (flushed: the watching job reads it at once)."""
    print(PREFIX + json.dumps(state, default=str), file=sys.stderr, flush=True)


def parse(line: str) -> dict | None:
    """The state of a progress line, or None when ``line`` is a plain log line."""
    line = line.rstrip("\n")
    if not line.startswith(PREFIX):
        return None
    try:
        d = json.loads(line[len(PREFIX):])
    except ValueError:
        return None
    return d if isinstance(d, dict) else None
