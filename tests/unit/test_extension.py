"""The repository is a valid Blender 5.0 extension, checked without importing bpy: Blender's own tool
(found inside the bpy wheel, run on plain Python) validates and builds it, and the built zip holds what it
should. Installing and enabling it in real Blender is tests/blender/test_extension.py."""
from __future__ import annotations

import shutil
import subprocess
import zipfile

from ..conftest import BLENDER_EXT, ROOT

TOOL = BLENDER_EXT


def test_validate_accepts_manifest_and_rejects_a_broken_one(tmp_path):
    p = subprocess.run([*TOOL, "validate", str(ROOT)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0 and "Success" in p.stdout, p.stdout + p.stderr
    # the tool is a real check: the same manifest without a license, or with an old Blender, is refused
    text = (ROOT / "blender_manifest.toml").read_text()
    for broken, why in ((text.replace('license = ["SPDX:GPL-3.0-or-later"]', ""), "license"),
                        (text.replace('blender_version_min = "5.0.0"', 'blender_version_min = "five"'), "blender_version_min")):
        assert broken != text
        d = tmp_path / why
        d.mkdir()
        (d / "blender_manifest.toml").write_text(broken)
        (d / "__init__.py").write_text("")
        shutil.copytree(ROOT / "wheels", d / "wheels")
        p = subprocess.run([*TOOL, "validate", str(d)], capture_output=True, text=True, timeout=60)
        assert p.returncode != 0 and why in p.stdout + p.stderr, (why, p.stdout, p.stderr)


def test_manifest_fields():
    import tomllib
    m = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    assert m["id"] == "ssgi" and m["type"] == "add-on"
    assert m["blender_version_min"] == "5.0.0"
    assert any("GPL" in lic for lic in m["license"])
    assert set(m["permissions"]) == {"files", "network"}
    for w in m["wheels"]:
        assert (ROOT / w).is_file(), w


def test_build_zip_contents(built_zip):
    names = zipfile.ZipFile(built_zip).namelist()
    tops = {n.split("/")[0] for n in names}
    for left_out in ("tests", ".ci", "scripts", ".venv", ".git", "docs", "out", "dist", "data", "Makefile",
                     "requirements.txt", "requirements.lock", "pytest.ini", ".gitignore"):
        assert left_out not in tops, left_out
    assert not [n for n in names if "__pycache__" in n or n.endswith((".pyc", ".tmp"))]
    for needed in ("blender_manifest.toml", "__init__.py", "cli.py", "ssgi_addon/__init__.py", "ssgi_addon/runtime/deps.py",
                   "ops/deps_ops.py", "panels/main_panel.py", "model/channels.py", "model/dataset/exrio.py"):
        assert needed in names, needed
    import tomllib
    for w in tomllib.loads((ROOT / "blender_manifest.toml").read_text())["wheels"]:  # this platform's (Linux x86-64)
        assert (w.removeprefix("./") in names) == w.endswith("manylinux_2_28_x86_64.whl"), w
    # every tracked package module of the checkout is in the zip
    tracked = subprocess.run(["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True).stdout.split()
    for f in tracked:
        if f.split("/")[0] in ("ssgi_addon", "ops", "panels", "model"):
            assert f in names, f


def test_built_zip_holds_no_benchmarks_docs_tests_or_dev_scripts(built_zip):
    """blender_manifest.toml's [build] leaves the side code out of the extension: measurements and tool scripts
    (benchmarks/), documentation (docs/), tests and their fixtures (tests/), dev scripts (scripts/), the scenes built by script (scenes/)."""
    names = zipfile.ZipFile(built_zip).namelist()
    for side in ("benchmarks/", "docs/", "tests/", "scripts/", "scenes/"):
        assert (ROOT / side).is_dir(), side  # the checkout has them: the test means something
        assert not [n for n in names if n.startswith(side)], side
    assert not [n for n in names if n.endswith(".blend")], names
