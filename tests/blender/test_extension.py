"""The repository is a valid Blender 5.0 extension: Blender's own tool validates and builds it, the built zip
installs and enables in real Blender (bpy module, isolated BLENDER_USER_RESOURCES), every class is registered,
disable/enable leaves nothing behind, and the bundled OpenEXR wheel is importable from the installed copy."""
from __future__ import annotations

import json

import pytest

from ..conftest import BLENDER_EXT, run_py

TOOL = BLENDER_EXT
PKG = "bl_ext.user_default.ssgi"


# One subprocess does the whole install / disable / enable round and reports what it saw as JSON; the tests
# below assert on that report. The meta-path finder hides the venv's own OpenEXR so that `import OpenEXR`
# can only succeed through the wheel the extension bundles.
_ROUND_TRIP = r'''
import importlib, importlib.machinery, inspect, json, pkgutil, site, sys
VENV_SITE = set(site.getsitepackages())
class HideVenvOpenEXR:
    def find_spec(self, name, path=None, target=None):
        if name in ("OpenEXR", "Imath"):
            spec = importlib.machinery.PathFinder.find_spec(name, [p for p in sys.path if p not in VENV_SITE])
            if spec is None:
                raise ImportError(f"{name} not found outside the venv")
            return spec
        return None
sys.meta_path.insert(0, HideVenvOpenEXR())

import bpy, addon_utils
PKG = "bl_ext.user_default.ssgi"
rep = {}
errors = []
bpy.ops.wm.read_factory_settings(use_empty=True)
r = bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default", enable_on_install=True)
rep["install_result"] = sorted(r)
mod = sys.modules[PKG]
rep["file"] = mod.__file__

REG_BASES = (bpy.types.Operator, bpy.types.Panel, bpy.types.PropertyGroup, bpy.types.AddonPreferences,
             bpy.types.Menu, bpy.types.UIList, bpy.types.Node, bpy.types.NodeTree, bpy.types.NodeSocket)

def expected():
    return [c for m in mod._modules() for c in getattr(m, "CLASSES", ())]

def defined_classes():
    """Every Blender class defined in a module of ops/, panels/ and ssgi_addon/ of the installed copy."""
    out, failed = {}, {}
    for sub in ("ssgi_addon", "ops", "panels"):
        p = importlib.import_module(f"{PKG}.{sub}")
        for info in pkgutil.walk_packages(p.__path__, prefix=f"{PKG}.{sub}."):
            name = info.name
            try:
                m = importlib.import_module(name)
            except Exception as e:
                failed[name] = f"{type(e).__name__}: {e}"
                continue
            for n, c in vars(m).items():
                if inspect.isclass(c) and issubclass(c, REG_BASES) and c.__module__ == name:
                    out[f"{name}.{n}"] = c
    return out, failed

def state():
    classes = expected()
    return {
        "expected": [c.__name__ for c in classes],
        "registered": {c.__name__: getattr(c, "is_registered", False) for c in classes},
        # operators, panels, menus and lists appear in bpy.types by name while registered
        "in_bpy_types": {c.__name__: getattr(bpy.types, c.__name__, None) is not None for c in classes
                         if issubclass(c, (bpy.types.Operator, bpy.types.Panel, bpy.types.Menu, bpy.types.UIList))},
        "scene_ssgi_type": (bpy.types.Scene.bl_rna.properties["ssgi"].fixed_type.identifier
                            if "ssgi" in bpy.types.Scene.bl_rna.properties else None),
        "ops": sorted(dir(bpy.ops.ssgi)),
        "scene_ssgi": hasattr(bpy.types.Scene, "ssgi"),
        "addon_enabled": PKG in bpy.context.preferences.addons,
        "check": list(addon_utils.check(PKG)),
    }

rep["enabled1"] = state()
defined, failed = defined_classes()
rep["defined"] = sorted(defined)
rep["defined_not_listed"] = sorted(k for k, c in defined.items() if c not in expected())
rep["import_failed"] = failed
s = bpy.context.scene
rep["scene_props"] = sorted(p.identifier for p in s.ssgi.bl_rna.properties if p.identifier != "rna_type")
prefs = bpy.context.preferences.addons[PKG].preferences
rep["prefs_type"] = type(prefs).__name__
rep["prefs_torch_threads"] = prefs.torch_threads

old_classes = expected()
jobs = importlib.import_module(PKG + ".ssgi_addon.runtime.jobs")
jobs.ensure_timer()  # as the installer operator does; disabling must take it away
rep["timer_before"] = bpy.app.timers.is_registered(jobs._timer)
addon_utils.disable(PKG, default_set=True, handle_error=lambda e: errors.append(f"disable: {e!r}"))
rep["disabled"] = state()
rep["disabled"]["old_registered"] = [c.__name__ for c in old_classes if getattr(c, "is_registered", False)]
rep["disabled"]["timer"] = bpy.app.timers.is_registered(jobs._timer)
addon_utils.enable(PKG, default_set=True, handle_error=lambda e: errors.append(f"enable: {e!r}"))
rep["enabled2"] = state()
rep["errors"] = errors

import OpenEXR, numpy as np
rep["openexr_file"] = OpenEXR.__file__
from bl_ext.user_default.ssgi.model.dataset import exrio
path = bpy.app.tempdir + "t.exr"
exrio.write_sample(path, {"depth": np.arange(6, dtype=np.float32).reshape(2, 3, 1)}, half=False)
rep["exr_roundtrip"] = exrio.read_sample(path, ("depth",))["depth"][..., 0].tolist()
rep["user_resources"] = bpy.utils.resource_path("USER")
print("REPORT" + json.dumps(rep))
'''


@pytest.fixture(scope="module")
def round_trip(built_zip) -> dict:
    p = run_py(_ROUND_TRIP, str(built_zip), timeout=300)
    line = next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))
    rep = json.loads(line[len("REPORT"):])
    rep["stderr"] = p.stderr
    return rep


def test_install_from_zip_enables_the_extension(round_trip):
    r = round_trip
    assert r["install_result"] == ["FINISHED"]
    assert r["file"].startswith(r["user_resources"]) and "/extensions/user_default/ssgi/" in r["file"]
    st = r["enabled1"]
    assert st["addon_enabled"] and st["check"] == [True, True]
    assert st["scene_ssgi"] and st["scene_ssgi_type"] == "SSGI_SceneSettings"
    assert {"dataset_dir", "model_path"} <= set(r["scene_props"])
    assert r["prefs_type"] == "SSGI_AddonPreferences" and r["prefs_torch_threads"] == 1


def test_every_class_is_registered(round_trip):
    st = round_trip["enabled1"]
    # the expected list comes from the CLASSES tuples of the modules in __init__._CLASS_MODULES
    assert len(st["expected"]) >= 5
    assert all(st["registered"].values()), st["registered"]
    assert {"SSGI_OT_install_deps", "SSGI_PT_main"} <= set(st["in_bpy_types"])
    assert all(st["in_bpy_types"].values()), st["in_bpy_types"]
    # a few known names, so that an empty CLASSES list cannot pass
    assert {"SSGI_SceneSettings", "SSGI_AddonPreferences", "SSGI_OT_install_deps", "SSGI_PT_main"} <= set(st["expected"])
    assert {"install_deps", "cancel_job"} <= set(st["ops"])
    # no Blender class defined in ssgi_addon/, ops/ or panels/ is missing from a CLASSES tuple
    assert not round_trip["import_failed"], round_trip["import_failed"]
    assert round_trip["defined_not_listed"] == [], round_trip["defined_not_listed"]


def test_disable_removes_everything_and_enable_restores(round_trip):
    assert round_trip["errors"] == []
    d = round_trip["disabled"]
    assert not d["addon_enabled"] and d["check"] == [False, False]
    assert d["old_registered"] == [] and not any(d["registered"].values())
    assert not any(d["in_bpy_types"].values()), d["in_bpy_types"]
    assert d["ops"] == [] and not d["scene_ssgi"]
    assert round_trip["timer_before"] and not d["timer"]  # the job pump timer goes with the add-on
    e = round_trip["enabled2"]
    assert e["addon_enabled"] and all(e["registered"].values()) and all(e["in_bpy_types"].values())
    assert e["scene_ssgi"] and set(e["ops"]) == set(round_trip["enabled1"]["ops"])
    assert "Traceback" not in round_trip["stderr"], round_trip["stderr"][-3000:]


def test_bundled_openexr_wheel_is_importable(round_trip):
    f = round_trip["openexr_file"]
    assert f.startswith(round_trip["user_resources"]) and "/extensions/.local/" in f, f
    assert round_trip["exr_roundtrip"] == [[0, 1, 2], [3, 4, 5]]
