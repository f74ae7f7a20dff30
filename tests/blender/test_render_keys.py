"""F12 and Ctrl+F12 with the extension enabled: keymap items of the extension's own (Blender checks the add-on key
configuration before its own) call ssgi.render_key, which renders the SSGI frame in a scene set up for SSGI and is
exactly Blender's render.render in any other scene. (The Render menu's own Render Image and a script's
bpy.ops.render.render() cannot be routed from Python: Blender starts that render itself, and a render_pre handler can
neither cancel it nor run another render inside it; they show the node's placeholder and say so.)"""
from __future__ import annotations

import json

import numpy as np

from ..conftest import run_py

_KEYS = r'''
import json, sys, bpy, ssgi
import numpy as np
from ssgi.ssgi_addon.blender import node
bpy.ops.wm.read_factory_settings(use_empty=False)
ssgi.register()
kc = bpy.context.window_manager.keyconfigs.addon
items = [(i.idname, i.type, i.ctrl, i.properties.animation) for km in kc.keymaps for i in km.keymap_items
         if i.idname == "ssgi.render_key"]
sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 36, 100
sc.eevee.taa_render_samples = 1
sc.render.image_settings.file_format = "OPEN_EXR"
def result():
    img = bpy.data.images["Render Result"]
    p = sys.argv[1] + "/r.exr"
    img.save_render(p, scene=sc)
    return p
r = {"items": items}
# a scene without SSGI: Blender's own render, and the same image as render.render
r["plain"] = sorted(bpy.ops.ssgi.render_key(animation=False))
r["plain_file"] = result()
import shutil; shutil.copy(r["plain_file"], sys.argv[1] + "/plain_key.exr")
bpy.ops.render.render()
shutil.copy(result(), sys.argv[1] + "/plain_own.exr")
# set up: the SSGI frame, not the placeholder
assert bpy.ops.ssgi.setup(model="one_render") == {"FINISHED"}
r["ssgi"] = sorted(bpy.ops.ssgi.render_key(animation=False))
shutil.copy(result(), sys.argv[1] + "/ssgi_key.exr")
r["state"] = node.image_state(sc).get("state")
from ssgi.ops import node_ops
from tests import ui_recorder
rec = ui_recorder.RecordingLayout()
node_ops.draw_render_menu(type("M", (), {"layout": rec})(), bpy.context)
r["menu_labels"] = rec.labels()
r["menu_first"] = bpy.types.TOPBAR_MT_render._dyn_ui_initialize()[0] is node_ops.draw_render_menu
bpy.ops.render.render()  # what the menu's Render Image does: the placeholder, said on stderr
shutil.copy(result(), sys.argv[1] + "/menu.exr")
r["after_plain"] = node.image_state(sc).get("state")
ssgi.unregister()
r["items_after_unregister"] = sum(1 for km in kc.keymaps for i in km.keymap_items if i.idname == "ssgi.render_key")
print("REPORT" + json.dumps(r))
'''


def _rgb(path):
    from .test_node import read_rgba
    return read_rgba(path)[..., :3]


def test_f12_renders_ssgi_in_a_set_up_scene_and_blenders_own_image_elsewhere(tmp_path):
    p = run_py(_KEYS, str(tmp_path), timeout=600)
    r = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])
    assert sorted(r["items"]) == [["ssgi.render_key", "F12", False, False], ["ssgi.render_key", "F12", True, True]]
    assert r["items_after_unregister"] == 0
    assert r["plain"] == ["FINISHED"] and r["ssgi"] == ["FINISHED"]
    assert np.array_equal(_rgb(tmp_path / "plain_key.exr"), _rgb(tmp_path / "plain_own.exr"))  # Blender's own
    ssgi_frame, menu = _rgb(tmp_path / "ssgi_key.exr"), _rgb(tmp_path / "menu.exr")
    magenta = np.array([1.0, 0.0, 1.0])
    assert r["state"] == "prediction" and np.abs(ssgi_frame - magenta).max(-1).min() > 0.05
    assert np.abs(ssgi_frame - _rgb(tmp_path / "plain_own.exr")).mean() > 1e-3  # light the plain render lacks
    assert r["after_plain"] == "placeholder" and "Press F12" in p.stderr
    # the Render menu says so before anything renders, at its top
    assert r["menu_first"] and any("F12 renders SSGI" in t for t in r["menu_labels"]), r["menu_labels"]
    assert (np.abs(menu - magenta).max(-1) < 1e-3).mean() > 0.5  # the menu's render: the placeholder it names
