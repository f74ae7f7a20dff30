"""Choosing a model in Blender: a menu of the shipped models (each with its one-line description) plus "Custom
file...", on the scene (Render Properties > SSGI) and on the node (where the first entry is the scene's model); the
render path uses what the menu shows; a file set before the menu existed shows as Custom; `--model NAME` takes a
shipped model's name on the command line."""
from __future__ import annotations

import json

from ..conftest import ROOT, run_cli, run_py

_MENU = r'''
import json, bpy, ssgi
from ssgi.model import shipped
from ssgi.panels import main_panel, node_panel
from ssgi.ssgi_addon.blender import node
from tests import ui_recorder
bpy.ops.wm.read_factory_settings(use_empty=False)
ssgi.register()
sc = bpy.context.scene
s = sc.ssgi
r = {"items": [(i.identifier, i.name, i.description) for i in s.bl_rna.properties["model_choice"].enum_items]}
def state():
    return [s.model_choice, s.model_path, node.resolve_model(sc).name]
r["start"] = state()
r["start_drawn"] = ui_recorder.draw(main_panel.SSGI_PT_main).props()
s.model_choice = "one_render"
r["one_render"] = state()
s.model_choice = "CUSTOM"
s.model_path = "/nowhere/fitted.pt"
r["custom"] = state()
r["custom_drawn"] = ui_recorder.draw(main_panel.SSGI_PT_main).props()
s.model_choice = "default"
r["back"] = state()
s.model_custom, s.model_path = False, "/nowhere/older.pt"  # a file saved before the menu: a path alone
r["older"] = s.model_choice
s.model_path = ""
# the node: its own menu over its model setting, first entry the scene's model
assert bpy.ops.ssgi.setup() == {"FINISHED"}
n = node.ssgi_nodes(sc.compositing_node_group)[0]
r["node_items"] = [i.identifier for i in n.bl_rna.properties["ssgi_model_choice"].enum_items]
r["node_start"] = [n.ssgi_model_choice, node.resolve_model(sc).name]
s.model_choice = "one_render"
r["node_scene_one"] = [n.ssgi_model_choice, node.resolve_model(sc).name]
n.ssgi_model_choice = "default"
r["node_default"] = [n.ssgi_model_choice, n.get("ssgi_model"), node.resolve_model(sc).name]
n.ssgi_model_choice = "SCENE"
r["node_back"] = [n.ssgi_model_choice, n.get("ssgi_model"), node.resolve_model(sc).name]
print("REPORT" + json.dumps(r))
'''


def test_the_model_menus_list_the_shipped_models_and_a_custom_file():
    p = run_py(_MENU, timeout=300)
    r = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("REPORT"))[len("REPORT"):])
    assert [i[0] for i in r["items"]] == ["default", "one_render", "CUSTOM"]
    assert all(len(i[2]) > 40 and "docs/" not in i[2] for i in r["items"]), r["items"]  # a tooltip that says what
    assert r["start"] == ["default", "", "ssgi_default.pt"]
    assert "model_choice" in r["start_drawn"] and "model_path" not in r["start_drawn"]  # the file field: Custom only
    assert r["one_render"] == ["one_render", "one_render", "ssgi_one_render.pt"]
    assert r["custom"] == ["CUSTOM", "/nowhere/fitted.pt", "fitted.pt"] and "model_path" in r["custom_drawn"]
    assert r["back"] == ["default", "", "ssgi_default.pt"]
    assert r["older"] == "CUSTOM"
    assert r["node_items"] == ["SCENE", "default", "one_render", "CUSTOM"]
    assert r["node_start"] == ["SCENE", "ssgi_default.pt"]
    assert r["node_scene_one"] == ["SCENE", "ssgi_one_render.pt"]  # the scene's choice, through the node
    assert r["node_default"] == ["default", "default", "ssgi_default.pt"]  # the node's own choice wins
    assert r["node_back"] == ["SCENE", "", "ssgi_one_render.pt"]


def test_model_takes_a_shipped_models_name_on_the_command_line(tmp_path):
    from ssgi.model.dataset import exrio
    from ssgi.model.infer import export
    g = export.hdr_groups(24, 16, seed=1)
    sample = tmp_path / "s.exr"
    from ssgi.model.infer import predictor
    need = predictor.load_predictor(ROOT / "models" / "ssgi_one_render.pt", runtime="onnx").required
    exrio.write_sample(sample, {k: g[k] for k in need}, half=False)
    d = json.loads(run_cli("predict", "--model", "one_render", "--input", str(sample), "--out",
                           str(tmp_path / "o.exr"), "--json").stdout)
    assert d["ok"] and d["model_file"].endswith("ssgi_one_render.onnx"), d
    p = run_cli("predict", "--model", "two_renders", "--input", str(sample), "--out", str(tmp_path / "o2.exr"),
                "--json", check=False)
    assert p.returncode == 2 and "two_renders" in json.loads(p.stdout)["error"]
