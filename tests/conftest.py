"""Shared test fixtures. Tests use the real bpy module (no fakes).

Every test process runs with ``BLENDER_USER_RESOURCES`` pointing at a fresh temporary folder and factory
settings, isolated from the user's own Blender config. EEVEE renders run in a subprocess (``run_py``), so
that a GL abort fails one test and not the whole run.
"""
from __future__ import annotations

import atexit
import json
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_USER_PREFIX = "ssgi-test-user-"
_USER_DIRS: list[str] = []  # the Blender user folders this process made; removed when it exits


def _user_dir() -> str:
    """A fresh temporary Blender user folder (``BLENDER_USER_RESOURCES``), removed at exit."""
    d = tempfile.mkdtemp(prefix=_USER_PREFIX)
    _USER_DIRS.append(d)
    return d


def _remove_user_dirs() -> None:
    """Remove only the folders ``_user_dir`` made in this process (a pytest-xdist worker removes its own): each
    must still be a real folder (not a link) named with our prefix in the temporary folder. SSGI_KEEP_TEST_USER=1
    keeps them for a look after a failure."""
    if os.environ.get("SSGI_KEEP_TEST_USER"):
        return
    tmp = os.path.realpath(tempfile.gettempdir())
    while _USER_DIRS:
        d = _USER_DIRS.pop()
        if (os.path.dirname(os.path.realpath(d)) == tmp and os.path.basename(d).startswith(_USER_PREFIX)
                and os.path.isdir(d) and not os.path.islink(d)):
            shutil.rmtree(d, ignore_errors=True)


# registered before bpy is imported, so it runs after bpy's own exit handlers (atexit runs last-in first-out)
atexit.register(_remove_user_dirs)
_USER = _user_dir()
os.environ["BLENDER_USER_RESOURCES"] = _USER
os.environ.setdefault("PYTHONHASHSEED", "0")
sys.path.insert(0, str(ROOT))

import cli  # noqa: E402

cli.load_package()  # the repository imported as package "ssgi"


def run_py(code: str, *args: str, timeout: float = 600, cwd: Path | None = None, env: dict | None = None,
           check: bool = True) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh Python of this venv (with bpy importable and the package loaded as ``ssgi``),
    isolated user resources. Returns the CompletedProcess; with ``check``, a non-zero exit fails the test
    and shows stderr."""
    user = _user_dir()
    prelude = f"import sys; sys.path.insert(0, {str(ROOT)!r}); import cli; cli.load_package()\n"
    e = dict(os.environ, BLENDER_USER_RESOURCES=user, PYTHONHASHSEED="0")
    e.update(env or {})
    p = subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code), *args], capture_output=True,
                       text=True, timeout=timeout, cwd=cwd or ROOT, env=e)
    if check and p.returncode != 0:
        pytest.fail(f"subprocess exited {p.returncode}\n--- stdout\n{p.stdout[-4000:]}\n--- stderr\n{clean(p.stderr)[-6000:]}")
    return p


def save_shot(name: str, path, size: tuple[int, int], last_frame: int, timeout: float = 180) -> None:
    """Build scenes/shots.py's shot ``name`` at ``size`` over frames 1..``last_frame``, at 1 EEVEE sample
    (tiny test renders), and save it to ``path``."""
    run_py(f'''
sys.path.insert(0, {str(ROOT)!r})
from scenes import shots as shot_scenes
sc = shot_scenes.build({name!r}, {tuple(size)!r}, {int(last_frame)})
sc.eevee.taa_render_samples = 1
shot_scenes.save(sc, {str(path)!r})
''', timeout=timeout)


def cornell_script(samples: int, size: tuple[int, int] = (64, 36)) -> str:
    """The head of a ``run_py`` script: ROOT, json, sys, numpy as np, bpy and scenes.artist imported, and
    ``sc`` a factory-empty scene holding artist_scenes' emissive Cornell box (lit only by an emissive ceiling panel, a
    planar emitter) at ``size`` and ``samples`` EEVEE samples."""
    return f'''ROOT = __import__("pathlib").Path({str(ROOT)!r})
import json, sys
import numpy as np
import bpy
sys.path.insert(0, str(ROOT))
from scenes import artist as artist_scenes

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
artist_scenes.build_cornell_emissive(sc)
artist_scenes.render_settings(sc, {tuple(size)!r})
sc.eevee.taa_render_samples = {int(samples)}
'''


ONE_RENDER_SHOT = (1, 20)  # the tiny one-render shot fits' frames


def one_render_shot_fit(tmp_path) -> tuple[Path, Path, dict, dict]:
    """A tiny one-render shot fit (``cli.py fit --one-render``) of shot_scenes' emissive Cornell box,
    frames ONE_RENDER_SHOT at 96x54, half a minute: (its .blend, the model, the fit's JSON summary, the checkpoint)."""
    import torch
    first, last = ONE_RENDER_SHOT
    blend = tmp_path / "cornell.blend"
    save_shot("cornell_emissive", blend, (96, 54), last)
    model = tmp_path / "shot.pt"
    p = run_cli("fit", "--blend", str(blend), "--out", str(model), "--frames", f"{first}-{last}", "--views", "6",
                "--minutes", "0.5", "--size", "96x54", "--ref-samples", "2", "--one-render",
                "--min-run-seconds", "1", "--threads", "1", "--crop", "32", "--json", timeout=1500)
    return blend, model, json.loads(p.stdout), torch.load(model, map_location="cpu", weights_only=False)


def strip_group(folder: Path, group: str, key: str = "000000") -> None:
    """Make ``folder`` look as an older bake wrote it: sample ``key`` without ``group``'s channels, a manifest
    without the group."""
    from ssgi.model.dataset import exrio
    path = Path(folder) / f"{key}.exr"
    planes, header = exrio.read_exr(path)
    exrio.write_exr(path, {c: p for c, p in planes.items() if not c.startswith(group + ".")},
                    header={k: v for k, v in header.items() if k.startswith("ssgi")})
    m = json.loads((Path(folder) / "manifest.json").read_text())
    m["channel_spec"] = [g for g in m["channel_spec"] if g["name"] != group]
    (Path(folder) / "manifest.json").write_text(json.dumps(m))


def run_cli(*args: str, timeout: float = 600, check: bool = True, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``cli.py ARGS`` in a subprocess with isolated user resources."""
    user = _user_dir()
    e = dict(os.environ, BLENDER_USER_RESOURCES=user, PYTHONHASHSEED="0")
    e.update(env or {})
    p = subprocess.run([sys.executable, str(ROOT / "cli.py"), *args], capture_output=True, text=True,
                       timeout=timeout, cwd=ROOT, env=e)
    if check and p.returncode != 0:
        pytest.fail(f"cli.py {' '.join(args)} exited {p.returncode}\n--- stdout\n{p.stdout[-4000:]}\n--- stderr\n{clean(p.stderr)[-6000:]}")
    return p


def clean(stderr: str) -> str:
    """Drop Mesa's harmless EGL chatter."""
    return "\n".join(l for l in stderr.splitlines() if "EGL Error" not in l and "EGL_BAD" not in l)


BLENDER_EXT = [sys.executable, str(ROOT / "scripts" / "blender_ext.py")]  # Blender's own extension tool


@pytest.fixture(scope="session")
def built_zips(tmp_path_factory) -> dict[str, Path]:
    """The extension's zips, one per platform ({"linux_x64": path, ...}), built from the working tree by Blender's
    own ``blender_ext.py build --split-platforms``, as `make build` builds them."""
    out = tmp_path_factory.mktemp("dist") / "out"  # does not exist yet: the wrapper must create it
    p = subprocess.run([*BLENDER_EXT, "build", "--source-dir", str(ROOT), "--output-dir", str(out),
                        "--split-platforms"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    return {z.stem.split("-")[-1]: z for z in sorted(out.glob("*.zip"))}


@pytest.fixture(scope="session")
def built_zip(built_zips) -> Path:
    """The zip of the platform the tests run on (Linux x86-64)."""
    return built_zips["linux_x64"]


# Makes `import torch` fail in every Python started with this folder on PYTHONPATH (sitecustomize runs at
# start-up), as in a Blender whose Python has no torch. bpy itself stays real.
_NO_TORCH = '''
import sys
class _NoTorch:
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch."):
            raise ImportError(f"No module named {name!r} (hidden by the SSGI test)")
        return None
sys.meta_path.insert(0, _NoTorch())
'''


@pytest.fixture(scope="session")
def no_torch_env(tmp_path_factory) -> dict:
    """``env=`` for run_py/run_cli: a subprocess in which ``import torch`` raises ImportError."""
    d = tmp_path_factory.mktemp("no_torch")
    (d / "sitecustomize.py").write_text(_NO_TORCH)
    return {"PYTHONPATH": str(d)}


@pytest.fixture
def factory_bpy():
    """The real bpy module, reset to factory settings."""
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy
