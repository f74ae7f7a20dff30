"""A compiled model (docs/compiled.md): a boxmlp network as one plain CompositorNodeGroup. Its output equals the numpy
graph of the same checkpoint on the same render's passes, and a copy set up by `cli.py setup --compiled` renders,
in a Python where the extension is not even imported, the frames the extension's own path renders. Real EEVEE at
64x36, 1 sample."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from ..conftest import ROOT, _user_dir, clean, cornell_script, run_cli, run_py, save_shot

# parity: relative to the pixel's value, with a floor for dark pixels (the ONNX parity's rule, docs/onnx.md)
PARITY, FLOOR = 1e-3, 0.01


@pytest.fixture(scope="module")
def boxmlp_model(tmp_path_factory):
    """A boxmlp checkpoint with seeded random weights, large enough that every unit changes the image."""
    import torch

    from ssgi.model.compile import graph
    from ssgi.model.learn import checkpoint, network
    torch.manual_seed(3)
    net = network.build(network.arch_for("boxmlp", ",".join(graph.SPEC), target="ref_combined", ref_width=64))
    with torch.no_grad():
        for p in net.parameters():
            p.mul_(2.0)
    path = tmp_path_factory.mktemp("compiled") / "boxmlp.pt"
    checkpoint.save(path, checkpoint.make(net, "network", command="test"))
    return path


def _rel(a, b):
    return float((np.abs(a - b) / np.maximum(np.abs(b), FLOOR)).max())


def test_the_group_renders_the_numpy_graph_of_its_render_s_passes(boxmlp_model, tmp_path):
    code = cornell_script(1) + f'''
from ssgi.model.compile import graph as cg
from ssgi.model.learn import checkpoint
from ssgi.ssgi_addon.blender import compiled, passes
info = compiled.setup_compiled(sc, {str(boxmlp_model)!r})
again = compiled.setup_compiled(sc, {str(boxmlp_model)!r})  # a second set-up replaces the group, adds nothing
groups = [n for n in sc.compositing_node_group.nodes if n.bl_idname == "CompositorNodeGroup"]
info["again"] = dict(groups=len(groups), trees=sum(1 for t in bpy.data.node_groups if compiled.LAYOUT_PROP in t),
                     proxies=again["proxies"], links=len(sc.compositing_node_group.links))
ims = sc.render.image_settings
ims.media_type, ims.file_format, ims.color_depth = "MULTI_LAYER_IMAGE", "OPEN_EXR_MULTILAYER", "32"
bpy.ops.render.render()
bpy.data.images["Render Result"].save_render({str(tmp_path / "r.exr")!r}, scene=sc)
rp = passes.read_multilayer({str(tmp_path / "r.exr")!r})
st = lambda name, comps: np.stack([rp[name][c] for c in comps], -1)
ps = {{"image": st("Combined", "RGB"), "albedo": st("Diffuse Color", "RGB"), "normal": st("Normal", "XYZ")}}
g = cg.from_checkpoint(checkpoint.load({str(boxmlp_model)!r}), 64)
np.save({str(tmp_path / "ref.npy")!r}, cg.evaluate(g, ps, compiled.frame_params(sc)))
np.save({str(tmp_path / "out.npy")!r}, st("Composite", "RGBA"))
np.save({str(tmp_path / "img.npy")!r}, st("Combined", "RGBA"))
print("RESULT", json.dumps({{k: v for k, v in info.items() if k != "ops"}}))
'''
    p = run_py(code, timeout=600)
    info = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    out, ref, img = (np.load(tmp_path / f"{n}.npy") for n in ("out", "ref", "img"))
    assert _rel(out[..., :3], ref) < PARITY, _rel(out[..., :3], ref)
    np.testing.assert_array_equal(out[..., 3], img[..., 3])  # the render's own alpha
    # the network changed EEVEE's GI-off image (a wrong wiring that passes the image through fails here)
    assert np.abs(out[..., :3] - img[..., :3]).mean() > 0.01 * img[..., :3].mean()
    # the emissive panel got its area-light proxy, kept in the file; 4 boxes: 14 shifts at 64 px wide
    assert info["proxies"] and info["width"] == 64 and info["nodes"] > 300, info
    assert info["again"] == dict(groups=1, trees=1, proxies=[], links=4), info["again"]




def _rgb(path):
    from ssgi.model.dataset import exrio
    planes, _ = exrio.read_exr(path)
    return np.stack([planes[c] for c in "RGB"], axis=-1)


def test_a_compiled_copy_renders_without_the_extension_the_frames_of_the_extension(boxmlp_model, tmp_path):
    blend = tmp_path / "shot.blend"
    save_shot("living_room", blend, (64, 36), 2)  # the camera moves: drivers turn the group's normals with it
    out = tmp_path / "shot_compiled.blend"
    p = run_cli("setup", "--blend", str(blend), "--out", str(out), "--compiled", "--model", str(boxmlp_model), "--json")
    info = json.loads(p.stdout)
    assert info["ok"] and info["camera_drivers"] == 9, info
    # a plain Python with bpy: nothing of the extension imported or enabled
    e = dict(os.environ, BLENDER_USER_RESOURCES=_user_dir())
    from ssgi.ssgi_addon.blender.compiled import PLAIN_RENDER
    p = subprocess.run([sys.executable, "-c", PLAIN_RENDER, str(out), str(tmp_path / "plain_####"), "1", "2"],
                       capture_output=True, text=True, timeout=600, cwd=tmp_path, env=e)
    assert p.returncode == 0, clean(p.stderr)[-3000:]
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert not res["ssgi_loaded"] and not any("ssgi" in a for a in res["addons"]), res
    run_cli("render", "--blend", str(blend), "--setup", "--model", str(boxmlp_model), "--frames", "1-2",
            "--out", str(tmp_path / "ext_####.exr"), "--working-res", "full", "--temporal", "off")
    plain = [_rgb(tmp_path / f"plain_{f:04d}.exr") for f in (1, 2)]
    ext = [_rgb(tmp_path / f"ext_{f:04d}.exr") for f in (1, 2)]
    for a, b in zip(plain, ext):
        assert _rel(a, b) < PARITY, _rel(a, b)
    assert np.abs(plain[0] - plain[1]).mean() > 1e-3  # two different frames, each its own


def test_setup_refuses_a_model_that_does_not_compile_in_one_line(tmp_path):
    blend = tmp_path / "c.blend"
    run_py(cornell_script(1) + f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})\n")
    for out, extra, words in ((tmp_path / "o.blend", ("--model", "one_render"), "does not compile into compositor nodes"),
                              (tmp_path / "o.blend", (), "ssgi_default.pt: a unet_s network does not compile"),
                              (blend, ("--model", "one_render"), "is the --blend file itself"),
                              (tmp_path / "o.png", ("--model", "one_render"), "must name a .blend file")):
        p = run_cli("setup", "--blend", str(blend), "--out", str(out), "--compiled", *extra, check=False)
        assert p.returncode == 2 and words in p.stderr and "Traceback" not in p.stderr, p.stderr[-2000:]
        assert not (tmp_path / "o.blend").exists()


def test_the_set_up_operator_compiles_and_the_cli_sets_up_the_extension_s_node_without_compiled(boxmlp_model, tmp_path):
    blend = tmp_path / "c.blend"
    p = run_py(cornell_script(1) + f'''
import ssgi
from ssgi.ssgi_addon.blender import compiled
ssgi.register()
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
try:  # (an operator's error report raises in the bpy module)
    bpy.ops.ssgi.setup(model="one_render", compiled=True)
    refused = "not refused"
except RuntimeError as e:
    refused = str(e)
untouched = sc.compositing_node_group is None and sc.eevee.use_raytracing
ok = bpy.ops.ssgi.setup(model={str(boxmlp_model)!r}, compiled=True)
tree = sc.compositing_node_group
from ssgi.panels import node_panel
from tests import ui_recorder
rec = ui_recorder.draw(node_panel.SSGI_PT_node)
print("RESULT", json.dumps({{"refused": refused, "untouched": untouched, "ok": sorted(ok), "labels": rec.labels(),
                             "ops": [o for o, _ in rec.operators()],
                             "groups": [n.node_tree.name for n in tree.nodes if n.bl_idname == "CompositorNodeGroup"
                                        and compiled.LAYOUT_PROP in n.node_tree],
                             "normal_pass": sc.view_layers[0].use_pass_normal, "gi": sc.eevee.use_raytracing}}))
''')
    res = json.loads(next(l for l in p.stdout.splitlines() if l.startswith("RESULT "))[7:])
    assert "does not compile into compositor nodes" in res.pop("refused"), res  # a bad model changes nothing
    # the panel says what the compositor holds, and offers both set-ups
    assert res.pop("labels")[0] == "Compiled: boxmlp.pt" and res.pop("ops") == ["ssgi.setup", "ssgi.setup"]
    assert res == dict(untouched=True, ok=["FINISHED"], groups=["SSGI compiled"], normal_pass=True, gi=False), res
    out = tmp_path / "node.blend"
    run_cli("setup", "--blend", str(blend), "--out", str(out))
    p = run_py(f'''
import bpy, json
from ssgi.ssgi_addon.blender import node
bpy.ops.wm.open_mainfile(filepath={str(out)!r})
print("RESULT", json.dumps(len(node.ssgi_nodes(bpy.context.scene.compositing_node_group))))
''')
    assert next(l for l in p.stdout.splitlines() if l.startswith("RESULT ")) == "RESULT 1"
