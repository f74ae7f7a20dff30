"""The product speaks of itself only: no tracked text file (code, comments, help texts, test names, docs, model
metadata) names a development session, a tracker issue number or a machine path. The project's history belongs in
CHANGELOG.md, which is the one file left out; binary files (checkpoints, ONNX files, images) are skipped.

The patterns are assembled from parts so that this file does not match them itself."""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_S, _I, _T, _W = "sess" + "ion", "iss" + "ue", "/" + "tmp/", "/" + "work/"
PATTERNS = re.compile("|".join([
    rf"\b{_S}s? [0-9]+(?:-[0-9]+)?",   # a development session, or a range of them
    rf"\b{_I}s? [0-9]+",               # a tracker issue
    re.escape(_T),                     # machine paths
    re.escape(_W),
]), re.IGNORECASE)
SKIPPED = {"CHANGELOG.md"}  # the history, by design


def is_binary(path: Path) -> bool:
    with open(path, "rb") as f:
        return b"\0" in f.read(8192)


def scan(paths, root: Path) -> list[str]:
    """``file:line: text`` of every line of the given files (relative to ``root``) that matches PATTERNS; binary
    and missing files are skipped."""
    hits = []
    for rel in paths:
        p = root / rel
        if not p.is_file() or is_binary(p):
            continue
        with open(p, encoding="utf-8", errors="replace") as f:
            for n, line in enumerate(f, 1):
                if PATTERNS.search(line):
                    hits.append(f"{rel}:{n}: {line.strip()[:160]}")
    return hits


def tracked_files() -> list[str]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: no list of tracked files")
    return [p for p in out.decode().split("\0") if p and p not in SKIPPED]


def test_no_tracked_file_names_a_session_an_issue_number_or_a_machine_path():
    hits = scan(tracked_files(), ROOT)
    assert not hits, (f"{len(hits)} line(s) speak of the project's history or a machine path (say what the code "
                      "does instead; history goes to CHANGELOG.md):\n" + "\n".join(hits))


def test_the_scan_finds_a_planted_session_and_a_machine_path(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text("x = 1\n"
                       f"# measured in {_S} 12\n"
                       "y = 2\n"
                       f"OUT = '{_T}x'\n"
                       f"# see {_I.capitalize()} 48\n"
                       "z = 'RenderSession(3) and /tmpfile are fine'\n")
    (tmp_path / "image.bin").write_bytes(b"\0" + f"{_S} 7".encode())
    hits = scan(["planted.py", "image.bin", "absent.txt"], tmp_path)
    assert [h.split(":")[:2] for h in hits] == [["planted.py", "2"], ["planted.py", "4"], ["planted.py", "5"]], hits
