"""torch inside the Blender app: detection with and without torch, the extension's private site-packages,
the pip command, the online-access check and the installer job run end to end against a tiny local wheel
(no network, torch is never downloaded)."""
from __future__ import annotations

import base64
import hashlib
import json
import zipfile
from pathlib import Path

import pytest

from ..conftest import run_cli, run_py

# modules that randomizing and baking use; they must import without torch (those not written yet are skipped
# inside the subprocess and listed in its report)
BAKE_SIDE_MODULES = ("model.errors", "model.channels", "model.dataset.exrio", "model.cliargs", "ssgi_addon.blender.room",
                     "ssgi_addon.blender.passes", "ssgi_addon.pipeline.bake", "ssgi_addon.randomize", "ssgi_addon.commands.info")


def make_wheel(folder: Path, name: str = "ssgi_probe_pkg", version: str = "1.0") -> Path:
    """A minimal pure-Python wheel (module ``name`` with VALUE = 42), made with zipfile: no build tools."""
    dist = f"{name}-{version}.dist-info"
    files = {
        f"{name}.py": f"VALUE = 42\nVERSION = {version!r}\n",
        f"{dist}/METADATA": f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n",
        f"{dist}/WHEEL": "Wheel-Version: 1.0\nGenerator: ssgi-test\nRoot-Is-Purelib: true\nTag: py3-none-any\n",
    }
    record = []
    for path, text in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(text.encode()).digest()).rstrip(b"=").decode()
        record.append(f"{path},sha256={digest},{len(text.encode())}")
    files[f"{dist}/RECORD"] = "\n".join(record + [f"{dist}/RECORD,,"]) + "\n"
    whl = folder / f"{name}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(whl, "w") as z:
        for path, text in files.items():
            z.writestr(path, text)
    return whl


def test_cli_info_without_torch(no_torch_env):
    p = run_cli("info", "--json", env=no_torch_env)
    d = json.loads(p.stdout)
    assert d["ok"] is True and d["torch"] is None
    assert "ImportError" in d["torch_error"] and "hidden by the SSGI test" in d["torch_error"]


_NO_TORCH_UI = r'''
import importlib, json, sys
import bpy
from tests import ui_recorder
PKG = "bl_ext.user_default.ssgi"
rep = {}
bpy.ops.wm.read_factory_settings(use_empty=True)
rep["install"] = sorted(bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default", enable_on_install=True))
mod = sys.modules[PKG]
deps = importlib.import_module(PKG + ".ssgi_addon.runtime.deps")
rep["torch_status"] = list(deps.torch_status())
rep["imported"], rep["absent"] = [], []
for name in json.loads(sys.argv[2]):
    try:
        importlib.import_module(f"{PKG}.{name}")
        rep["imported"].append(name)
    except ModuleNotFoundError as e:
        if e.name != f"{PKG}.{name}":
            raise
        rep["absent"].append(name)
panels = [c for m in mod._modules() for c in getattr(m, "CLASSES", ()) if issubclass(c, bpy.types.Panel)]
rep["panels"] = {}
for cls in panels:
    if hasattr(cls, "poll") and not cls.poll(bpy.context):
        continue
    rec = ui_recorder.draw(cls)
    rep["panels"][cls.__name__] = {"labels": rec.labels(), "operators": rec.operators(), "props": rec.props()}
prefs = bpy.context.preferences.addons[PKG].preferences
rec = ui_recorder.draw(type(prefs), prefs)
rep["prefs"] = {"labels": rec.labels(), "operators": rec.operators(), "props": rec.props()}
rep["online_access"] = bpy.app.online_access
rep["torch_in_modules"] = "torch" in sys.modules
print("REPORT" + json.dumps(rep))
'''


def _report(p) -> dict:
    return json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])


def test_without_torch_extension_enables_panels_draw_and_bake_side_imports(built_zip, no_torch_env):
    r = _report(run_py(_NO_TORCH_UI, str(built_zip), json.dumps(BAKE_SIDE_MODULES), env=no_torch_env, timeout=300))
    assert r["install"] == ["FINISHED"]
    ok, why = r["torch_status"]
    assert ok is False and "ImportError" in why
    assert {"model.channels", "model.dataset.exrio", "model.cliargs"} <= set(r["imported"]), r
    assert r["torch_in_modules"] is False  # nothing imported torch behind the blocker's back either
    main = r["panels"]["SSGI_PT_main"]
    assert any("PyTorch missing" in t for t in main["labels"]), main
    assert {"dataset_dir", "model_choice"} <= set(main["props"])  # the model menu (its file field: Custom only)
    p = r["prefs"]
    assert "PyTorch: not installed" in p["labels"]
    # the installer is shown, greyed out while online access is off (the factory default in background)
    assert r["online_access"] is False
    assert ("ssgi.install_deps", False) in [tuple(o) for o in p["operators"]]
    assert any("online access" in t.lower() for t in p["labels"])


_INSTALLER = r'''
import importlib, json, os, sys
from pathlib import Path
import bpy
from tests import ui_recorder
PKG = "bl_ext.user_default.ssgi"
rep = {}
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default", enable_on_install=True)
deps = importlib.import_module(PKG + ".ssgi_addon.runtime.deps")
jobs = importlib.import_module(PKG + ".ssgi_addon.runtime.jobs")
prefs = bpy.context.preferences.addons[PKG].preferences

# --- paths ---
d = deps.deps_dir()
rep["deps_dir"] = str(d)
rep["extension_path_user"] = bpy.utils.extension_path_user(PKG, path="site-packages")
rep["user_resources"] = bpy.utils.resource_path("USER")
rep["exists_before"] = d.exists()
d = deps.deps_dir(create=True)
rep["exists_after_create"] = d.is_dir()
import ssgi.ssgi_addon.runtime.deps as checkout_deps  # the checkout, as cli.py loads it in a Blender binary
rep["checkout_deps_dir"] = str(checkout_deps.deps_dir())
(d / "ssgi_probe_path.py").write_text("WHERE = 'extension site-packages'\n")
rep["add_to_path"] = str(deps.add_to_path())
rep["sys_path0"] = sys.path[0]
import ssgi_probe_path
rep["probe_file"] = ssgi_probe_path.__file__
rep["pip_default"] = deps.pip_command(d)
rep["pip_extra"] = deps.pip_command(d, "pkg==1", extra_args="--no-index --find-links '/a b'")
try:
    deps.pip_command(d, "  ")
    rep["pip_empty"] = "accepted"
except Exception as e:
    rep["pip_empty"] = f"{type(e).__name__}: {e}"

# --- online access off: the operator refuses and starts nothing ---
rep["online0"] = bpy.app.online_access
try:
    rep["op_offline"] = sorted(bpy.ops.ssgi.install_deps())
except RuntimeError as e:  # an operator's ERROR report is raised in Python
    rep["op_offline"] = str(e)
rep["job_after_offline"] = jobs.get("deps") is not None

# --- online access on: the real operator and job, pip against a local wheel folder ---
bpy.context.preferences.system.use_online_access = True
rep["online1"] = bpy.app.online_access
prefs.pip_requirement = "ssgi-probe-pkg==1.0"
prefs.pip_extra_args = f"--no-index --find-links {sys.argv[2]}"
rep["op_online"] = sorted(bpy.ops.ssgi.install_deps())
job = jobs.get("deps")
rep["job_running_at_start"] = not job.done
job.wait(timeout=240)
rep["job_ok"] = {"status": job.state["status"], "result": job.result, "error": job.error, "message": job.state["message"]}
import ssgi_probe_pkg
rep["probe_pkg"] = [ssgi_probe_pkg.VALUE, ssgi_probe_pkg.__file__]
rec = ui_recorder.draw(type(prefs), prefs)
rep["prefs_after_ok"] = rec.labels()

# --- a failing install is reported, not raised ---
prefs.pip_requirement = "ssgi-probe-pkg==9.9"
bpy.ops.ssgi.install_deps()
job = jobs.get("deps")
job.wait(timeout=240)
rep["job_fail"] = {"status": job.state["status"], "error": job.error, "message": job.state["message"]}
rec = ui_recorder.draw(type(prefs), prefs)
rep["prefs_after_fail"] = rec.labels()
print("REPORT" + json.dumps(rep))
'''


@pytest.fixture(scope="module")
def installer_report(built_zip, tmp_path_factory) -> dict:
    wheels = tmp_path_factory.mktemp("wheels")
    make_wheel(wheels)
    return _report(run_py(_INSTALLER, str(built_zip), str(wheels), timeout=600))


def test_deps_dir_is_the_extensions_user_folder(installer_report):
    r = installer_report
    assert r["deps_dir"] == r["extension_path_user"]
    assert r["deps_dir"].startswith(r["user_resources"])
    assert r["deps_dir"].endswith("/extensions/.user/user_default/ssgi/site-packages")
    assert r["exists_before"] is False and r["exists_after_create"] is True
    # loaded from the checkout (cli.py in a Blender binary), deps finds the installed extension's folder
    assert r["checkout_deps_dir"] == r["deps_dir"]


def test_add_to_path_puts_it_first_and_makes_modules_importable(installer_report):
    r = installer_report
    assert r["add_to_path"] == r["deps_dir"] == r["sys_path0"]
    assert r["probe_file"] == r["deps_dir"] + "/ssgi_probe_path.py"


def test_pip_command_targets_the_folder(installer_report):
    r = installer_report
    cmd = r["pip_default"]
    assert cmd[1:4] == ["-m", "pip", "install"]
    assert cmd[cmd.index("--target") + 1] == r["deps_dir"]
    assert cmd[-1] == "torch==2.13.0"
    extra = r["pip_extra"]
    assert extra[-3:] == ["--find-links", "/a b", "pkg==1"] and "--no-index" in extra
    assert "UserError" in r["pip_empty"]


def test_installer_refuses_without_online_access(installer_report):
    r = installer_report
    assert r["online0"] is False
    assert "Online access is disabled" in r["op_offline"]
    assert r["job_after_offline"] is False


def test_installer_job_end_to_end_with_local_wheel(installer_report):
    r = installer_report
    assert r["online1"] is True and r["op_online"] == ["FINISHED"]
    ok = r["job_ok"]
    assert ok["status"] == "done" and ok["error"] is None, ok
    assert ok["result"]["target"] == r["deps_dir"]
    assert r["probe_pkg"][0] == 42 and r["probe_pkg"][1] == r["deps_dir"] + "/ssgi_probe_pkg.py"
    assert "installed" in ok["message"]
    assert any("installed" in t for t in r["prefs_after_ok"]), r["prefs_after_ok"]
    fail = r["job_fail"]
    assert fail["status"] == "error" and "pip exited with status" in fail["error"]
    assert any(t.startswith("Install failed: pip exited") for t in r["prefs_after_fail"]), r["prefs_after_fail"]
