"""`make build` writes one extension zip per platform (Blender's `blender_ext.py build --split-platforms`): each holds
the onnxruntime and OpenEXR wheels of its own platform and no other, pinned by wheels/SHA256SUMS, its manifest names
that platform alone, every other file is the same in all of them, and Blender's `validate` accepts each. (Only the
Linux x86-64 zip is installed and rendered with by the tests here: test_onnx_install.py, test_deps.py.)"""
from __future__ import annotations

import hashlib
import subprocess
import tomllib
import zipfile

from ..conftest import BLENDER_EXT, ROOT

# the wheel platform tags each Blender platform takes (blender_ext.py's mapping)
TAGS = {"linux_x64": ("manylinux_2_28_x86_64",), "linux_arm64": ("manylinux_2_28_aarch64",),
        "windows_x64": ("win_amd64",), "windows_arm64": ("win_arm64",),
        "macos_arm64": ("macosx_11_0_arm64", "macosx_14_0_arm64")}


def test_one_zip_per_platform_each_with_its_own_wheels_and_the_same_files(built_zips):
    assert set(built_zips) == set(TAGS), sorted(built_zips)
    pinned = dict(line.split()[::-1] for line in (ROOT / "wheels" / "SHA256SUMS").read_text().splitlines() if line)
    shared = {}
    for plat, path in built_zips.items():
        with zipfile.ZipFile(path) as z:
            manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
            gen = manifest["build"]["generated"]
            assert gen["platforms"] == [plat.replace("_", "-")], (plat, gen)
            wheels = sorted(n for n in z.namelist() if n.startswith("wheels/") and n.endswith(".whl"))
            assert sorted(w.lstrip("./") for w in gen["wheels"]) == wheels, (plat, wheels)
            assert sorted(w.split("/")[1].split("-")[0] for w in wheels) == ["onnxruntime", "openexr"], (plat, wheels)
            for w in wheels:
                tag = w[:-len(".whl")].rsplit("-", 1)[1]
                assert tag in TAGS[plat], (plat, w)
                assert hashlib.sha256(z.read(w)).hexdigest() == pinned[w.split("/")[1]], w
            files = {n: z.read(n) for n in z.namelist()
                     if not n.endswith("/") and n not in wheels and n != "blender_manifest.toml"}
        assert "farm_render.py" in files and "models/ssgi_default.onnx" in files and "models/ssgi_one_render.onnx" in files
        shared[plat] = files
    first = shared["linux_x64"]
    for plat, files in shared.items():
        assert files.keys() == first.keys(), plat
        assert all(files[n] == first[n] for n in files), plat


def test_blenders_validate_accepts_each_zip(built_zips):
    for plat, path in built_zips.items():
        p = subprocess.run([*BLENDER_EXT, "validate", str(path)], capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, (plat, p.stdout + p.stderr)
