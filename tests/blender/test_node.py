"""The SSGI compositor node and render path, on real bpy + EEVEE at 64x36, 1 sample, in subprocesses.

One module fixture builds a small room (.blend, SSGI set up by the operator, a random checkpoint); another
renders it once through the SSGI path in a subprocess and keeps the passes of that very render, so the
tests below can check the written frames against ``predict()`` computed here, independently.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from ..conftest import clean, run_cli, run_py

W, H = 64, 36

# A room: floor, a low back wall (sky visible above it), a red cube, a sphere, a point light, a camera that
# moves along x over frames 1..3, a blue world. Output: 32-bit RGBA OpenEXR.
SCENE = '''
import bpy, math
def build_room(out_pattern):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "BLENDER_EEVEE"
    sc.eevee.taa_render_samples = 1
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 36, 100
    bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, 0))
    bpy.ops.mesh.primitive_plane_add(size=3, location=(0, 3, 1.5), rotation=(math.pi / 2, 0, 0))
    bpy.ops.mesh.primitive_cube_add(size=1, location=(-0.8, 0.5, 0.5))
    m = bpy.data.materials.new("red")
    m.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.1, 0.1, 1)
    bpy.context.object.data.materials.append(m)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.9, 0.2, 0.5))
    bpy.ops.object.light_add(type="POINT", location=(0.5, -1.0, 2.5))
    bpy.context.object.data.energy = 300
    bpy.ops.object.camera_add(location=(0, -5, 1.6), rotation=(math.radians(90), 0, 0))
    cam = bpy.context.object
    sc.camera = cam
    for f, x in ((1, -0.4), (2, 0.0), (3, 0.4)):
        cam.location.x = x
        cam.keyframe_insert("location", frame=f)
    sc.frame_start, sc.frame_end = 1, 3
    sc.frame_set(2)
    world = bpy.data.worlds.new("World")
    sc.world = world
    world.color = (0.05, 0.1, 0.3)
    bg = world.node_tree.nodes.get("Background") if world.node_tree else None
    if bg is not None:
        bg.inputs[0].default_value = (0.05, 0.1, 0.3, 1)
    ims = sc.render.image_settings
    ims.file_format = "OPEN_EXR"
    ims.color_depth = "32"
    ims.color_mode = "RGBA"
    sc.render.filepath = out_pattern
    return sc
'''

SNAPSHOT = '''
def settings_snapshot(sc):
    """Plain settings that the SSGI path changes while it renders, and the compositor's links."""
    def plain(s):
        out = {}
        for p in s.bl_rna.properties:
            if p.identifier == "rna_type" or p.type not in ("BOOLEAN", "INT", "FLOAT", "STRING", "ENUM"):
                continue
            v = getattr(s, p.identifier)
            out[p.identifier] = list(v) if hasattr(v, "__len__") and not isinstance(v, str) else (sorted(v) if isinstance(v, set) else v)
        return out
    lights = {o.name: plain(o.data) for o in sc.objects if o.type == "LIGHT"}
    tree = sc.compositing_node_group
    return {"eevee": plain(sc.eevee), "render": plain(sc.render), "image_settings": plain(sc.render.image_settings),
            "view_layer": plain(sc.view_layers[0]), "lights": lights, "world": sc.world.name if sc.world else None,
            "frame": sc.frame_current, "nodes": sorted((n.name, n.bl_idname, n.mute, n.label) for n in tree.nodes),
            "links": sorted((l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
                            for l in tree.links)}
'''


def read_rgba(path) -> np.ndarray:
    import OpenEXR
    with OpenEXR.File(str(path), separate_channels=True) as f:
        ch = f.parts[0].channels
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in "RGBA"], -1)


def make_checkpoint(path: Path, variant: str = "unet_s", inputs=None) -> Path:
    """A small randomly initialised checkpoint, through model/checkpoint.py's save API."""
    import torch

    from ssgi.model import channels as ch
    from ssgi.model.learn import checkpoint, network
    torch.manual_seed(0)
    net = network.build(network.arch_for(variant, inputs=inputs or ch.DEFAULT_INPUTS))
    ck = checkpoint.make(net, "network", command="tests/test_node.py")
    ck["versions"] = {k: str(v) for k, v in ck["versions"].items()}  # plain strings load with weights_only
    checkpoint.save(path, ck)
    return path


def expected_image(model: Path, groups: dict, clip_end: float) -> np.ndarray:
    """What the node must show, computed here: predict() on the passes; a whole-image model with EEVEE's colour
    where no geometry, a diffuse-part model plus EEVEE's own rest."""
    from ssgi.model.infer import predictor
    p = predictor.load_predictor(model)
    pred = p.predict(groups)
    world = groups["depth"][..., 0] >= 0.999 * clip_end
    if p.target == "ref_diffuse":
        return np.maximum(pred + groups["rest"][..., :3], 0), world
    return np.where(world[..., None], groups["eevee"][..., :3], pred), world


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    d = tmp_path_factory.mktemp("node")
    model = make_checkpoint(d / "model.pt")
    blend = d / "room.blend"
    run_py(SCENE + f'''
import ssgi
ssgi.register()
sc = build_room({str(d / "out" / "f_####")!r})
assert bpy.ops.ssgi.setup(model={str(model)!r}) == {{"FINISHED"}}
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
''', timeout=300)
    return {"dir": d, "model": model, "blend": blend}


@pytest.fixture(scope="module")
def rendered(room):
    """One subprocess: SSGI render of frame 2 (passes kept), a plain render, Invert + a pass mix after SSGI
    rendered again, bpy.ops.ssgi.render, and the .blend saved after all that."""
    d = room["dir"]
    res = d / "rendered.json"
    p = run_py(SCENE + SNAPSHOT + f'''
import json, numpy as np, ssgi
from ssgi.ssgi_addon.pipeline import render as R
ssgi.register()
bpy.ops.wm.open_mainfile(filepath={str(room["blend"])!r})
sc = bpy.context.scene
out = {{}}
before = settings_snapshot(sc)
s = R.RenderSession(sc, [2], keep_groups=True)
s.run()
out["after_equal"] = settings_snapshot(sc) == before
out["diff"] = {{k: (before[k], settings_snapshot(sc)[k]) for k in before if before[k] != settings_snapshot(sc)[k]}}
info = s.results[0]
out["plain_ssgi"] = info["path"]
from tests import ui_recorder
from ssgi.panels import node_panel
out["panel_after_ssgi"] = ui_recorder.draw(node_panel.SSGI_PT_render).labels()
np.savez({str(d / "g1.npz")!r}, **info["groups"])
out["clip_end"] = sc.camera.data.clip_end
# a plain render: must not show the prediction just made
sc.render.filepath = {str(d / "plain")!r}
bpy.ops.render.render(write_still=True)
img = bpy.data.images["SSGI Prediction"]
out["after_plain_state"] = img.get("ssgi_state")
out["panel_after_plain"] = ui_recorder.draw(node_panel.SSGI_PT_render).labels()
out["label_after_plain"] = next(n.label for n in sc.compositing_node_group.nodes if n.name == "SSGI")
sc.render.filepath = {str(d / "out" / "f_####")!r}
# the artist's nodes after SSGI: Invert, then add Render Layers' Diffuse Color
tree = sc.compositing_node_group
ssgi_node = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeGroup")
rl = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers")
gout = next(n for n in tree.nodes if n.bl_idname == "NodeGroupOutput")
inv = tree.nodes.new("CompositorNodeInvert")
mix = tree.nodes.new("ShaderNodeMix"); mix.data_type = "RGBA"; mix.blend_type = "ADD"
mix.inputs["Factor"].default_value = 1.0
tree.links.new(ssgi_node.outputs[0], inv.inputs["Color"])
tree.links.new(inv.outputs[0], mix.inputs[6])
tree.links.new(rl.outputs["Diffuse Color"], mix.inputs[7])
tree.links.new(mix.outputs[2], gout.inputs[0])
s2 = R.RenderSession(sc, [2], out={str(d / "inverted")!r}, keep_groups=True)
s2.run()
out["inverted"] = s2.results[0]["path"]
np.savez({str(d / "g2.npz")!r}, **s2.results[0]["groups"])
out["op"] = sorted(bpy.ops.ssgi.render(write_still=True, filepath={str(d / "op_####")!r}))
out["op_file"] = {str(d / "op_0002.exr")!r}
bpy.ops.wm.save_as_mainfile(filepath={str(d / "rendered.blend")!r})
# transparent film at an odd size and aspect, SSGI straight to the output
sc.render.film_transparent = True
sc.render.resolution_x, sc.render.resolution_y = 50, 31
tree.links.new(ssgi_node.outputs[0], gout.inputs[0])
s3 = R.RenderSession(sc, [2], out={str(d / "transparent")!r}, keep_groups=True)
s3.run()
out["transparent"] = s3.results[0]["path"]
np.savez({str(d / "g3.npz")!r}, **s3.results[0]["groups"])
# cancel after the first of three frames
s4 = R.RenderSession(sc, [1, 2, 3], out={str(d / "cancel" / "c_####")!r})
out["cancel"] = s4.run(should_cancel=lambda: len(s4.results) >= 1)
json.dump(out, open({str(res)!r}, "w"), default=str)
''', timeout=600)
    r = json.loads(res.read_text())
    r["stderr"] = clean(p.stderr)
    r["g1"] = dict(np.load(d / "g1.npz"))
    r["g2"] = dict(np.load(d / "g2.npz"))
    r["g3"] = dict(np.load(d / "g3.npz"))
    return r


def test_composite_output_equals_prediction_of_the_same_render(room, rendered):
    got = read_rgba(rendered["plain_ssgi"])
    assert got.shape == (H, W, 4)
    exp, world = expected_image(room["model"], rendered["g1"], rendered["clip_end"])
    assert 0 < world.sum() < world.size * 0.6, "the test scene must show both sky and geometry"
    np.testing.assert_allclose(got[..., :3], exp, rtol=1e-5, atol=1e-6)
    assert np.all(got[..., 3] == 1.0)
    # the node shows the prediction, not EEVEE's own image, on geometry
    eevee = rendered["g1"]["eevee"][..., :3]
    assert np.abs(got[..., :3] - eevee)[~world].mean() > 1e-3
    assert Path(rendered["plain_ssgi"]).name == "f_0002.exr"


def test_scene_settings_and_tree_are_put_back_after_an_ssgi_render(rendered):
    assert rendered["after_equal"], rendered["diff"]


def test_plain_render_shows_placeholder_not_the_stale_prediction(rendered):
    plain = read_rgba(Path(rendered["plain_ssgi"]).parent.parent / "plain.exr")
    np.testing.assert_array_equal(plain[..., :3], np.broadcast_to(np.float32([1, 0, 1]), plain[..., :3].shape))
    assert rendered["after_plain_state"] == "placeholder"
    assert "placeholder, not a prediction" in rendered["stderr"]
    # the node and the panel say so too; right after the SSGI render the panel said the image was current
    assert rendered["label_after_plain"] == "SSGI: placeholder, use Render SSGI"
    assert "Shows frame 2 (current)" in rendered["panel_after_ssgi"]
    assert "Placeholder (magenta): render with SSGI" in rendered["panel_after_plain"]


def test_nodes_after_ssgi_apply_invert_and_pass_mix(room, rendered):
    got = read_rgba(rendered["inverted"])
    g = rendered["g2"]
    exp, _ = expected_image(room["model"], g, rendered["clip_end"])
    # Invert, then + Render Layers' Diffuse Color (fed by the stand-in of the same render)
    np.testing.assert_allclose(got[..., :3], (1.0 - exp) + g["albedo"], rtol=1e-5, atol=1e-5)
    assert Path(rendered["inverted"]).name == "inverted.exr"


def test_transparent_film_keeps_alpha_at_an_odd_size(room, rendered):
    got = read_rgba(rendered["transparent"])
    g = rendered["g3"]
    assert got.shape == (31, 50, 4)
    exp, world = expected_image(room["model"], g, rendered["clip_end"])
    alpha = g["eevee"][..., 3]
    assert (alpha == 0).sum() > 0 and (alpha == 1).sum() > 0
    np.testing.assert_array_equal(got[..., 3], alpha)
    np.testing.assert_allclose(got[..., :3], exp, rtol=1e-5, atol=1e-6)
    assert np.all(got[..., :3][alpha == 0] == 0)


def test_cancel_keeps_the_frames_already_written(room, rendered):
    c = rendered["cancel"]
    assert c["cancelled"] is True and c["frames"] == [1]
    files = sorted(p.name for p in (room["dir"] / "cancel").iterdir())
    # no frame 2/3, no temporary file left; the temporal mode's history stays for a resume (hidden folder)
    assert [f for f in files if f != ".ssgi_history"] == ["c_0001.exr"]
    assert read_rgba(room["dir"] / "cancel" / "c_0001.exr").shape == (31, 50, 4)


def test_operator_renders_and_writes_where_asked(rendered):
    assert rendered["op"] == ["FINISHED"]
    op = read_rgba(rendered["op_file"])
    inv = read_rgba(rendered["inverted"])
    # same frame, same tree, a second EEVEE render: the same image
    np.testing.assert_allclose(op, inv, atol=1e-4)


def test_render_job_steps_frame_by_frame_and_the_one_cancel_stops_it(room, tmp_path):
    """The Render SSGI operator's main-thread job (ui_jobs.render), stepped by hand as its modal timer would:
    one frame per step; ssgi.cancel_job stops it before the next frame, keeping the frame written; the panel
    draws the running job with the one Cancel button, then how it ended."""
    res = tmp_path / "job.json"
    run_py(f'''
import json, bpy, ssgi
from ssgi.ssgi_addon.runtime import jobs, ui_jobs
from ssgi.panels import node_panel
from tests import ui_recorder
ssgi.register()
bpy.ops.wm.open_mainfile(filepath={str(room["blend"])!r})
sc = bpy.context.scene
job = ui_jobs.render(sc, [1, 2, 3], out={str(tmp_path / "j_####")!r}).start()
r = {{"after_start": [job.state[k] for k in ("status", "done", "todo")], "step1": job.step()}}
rec = ui_recorder.draw(node_panel.SSGI_PT_render)
r["running_ops"] = [o for o, _ in rec.operators()]
r["running_text"] = [e["kw"].get("text") for e in rec.log if e["fn"] == "progress"]
r["cancel"] = sorted(bpy.ops.ssgi.cancel_job(job="render"))
r["step2"] = job.step()
r["state"] = [job.state["status"], job.result["cancelled"], job.result["frames"]]
r["labels"] = ui_recorder.draw(node_panel.SSGI_PT_render).labels()
json.dump(r, open({str(res)!r}, "w"))
''', timeout=300)
    r = json.loads(res.read_text())
    assert r["after_start"] == ["running", 0, 3] and r["step1"] is True
    assert "ssgi.cancel_job" in r["running_ops"] and "1/3" in r["running_text"][0]
    assert r["cancel"] == ["FINISHED"] and r["step2"] is False
    assert r["state"] == ["cancelled", True, [1]]
    assert sorted(p.name for p in tmp_path.glob("j_*")) == ["j_0001.exr"]
    assert any(l.startswith("Cancelled: 1 frame(s)") for l in r["labels"]), r["labels"]


def test_step_jobs_cancelled_before_their_first_step_end_with_a_summary(room, tmp_path):
    """A Cancel (or Esc, or disabling the add-on) that comes after Render SSGI or Bake Dataset started but before
    their first timer tick: the job ends "cancelled" with a summary (no frame, no sample), nothing written, and
    the operator's closing report does not fail on it."""
    res = tmp_path / "early.json"
    run_py(f'''
import json, bpy, ssgi
from ssgi.ssgi_addon.runtime import jobs, ui_jobs
ssgi.register()
bpy.ops.wm.open_mainfile(filepath={str(room["blend"])!r})
sc = bpy.context.scene
r = {{}}
job = ui_jobs.render(sc, [1, 2], out={str(tmp_path / "e_####")!r}).start()
job.cancel()
r["render"] = [job.step(), job.state["status"], job.result["cancelled"], job.result["frames"]]
sc.ssgi.dataset_dir = {str(tmp_path / "data")!r}
sc.ssgi.bake_count, sc.ssgi.bake_width, sc.ssgi.bake_height = 2, 16, 9
job = ui_jobs.bake(sc).start()
job.cancel()
r["bake"] = [job.step(), job.state["status"], job.result["status"], job.result["baked"]]
r["scenes"] = sorted(s.name for s in bpy.data.scenes)
json.dump(r, open({str(res)!r}, "w"))
''', timeout=300)
    r = json.loads(res.read_text())
    assert r["render"] == [False, "cancelled", True, []]
    assert r["bake"] == [False, "cancelled", "cancelled", 0]
    assert not list(tmp_path.glob("e_*")) and not list((tmp_path / "data").glob("0*.exr"))
    assert not any("SSGI Bake" in n for n in r["scenes"])  # the bake's scratch scene is gone


def test_blend_reopens_and_renders_without_the_extension(room, rendered):
    """The saved file on a Blender where the extension is not enabled: the SSGI node is a plain group, the
    render does not crash, and it shows the placeholder (pixels of the prediction are not saved)."""
    d = room["dir"]
    res = d / "noext.json"
    run_py(f'''
import bpy, json, numpy as np, addon_utils
assert not any(m.__name__.endswith("ssgi") for m in addon_utils.modules() if addon_utils.check(m.__name__)[1])
assert not hasattr(bpy.types, "SSGI_OT_render")
bpy.ops.wm.open_mainfile(filepath={str(d / "rendered.blend")!r})
sc = bpy.context.scene
n = next(n for n in sc.compositing_node_group.nodes if n.name == "SSGI")
img = bpy.data.images["SSGI Prediction"]
px = np.empty(len(img.pixels), np.float32); img.pixels.foreach_get(px)
sc.render.filepath = {str(d / "noext")!r}
bpy.ops.render.render(write_still=True)
json.dump({{"type": n.bl_idname, "tree": n.node_tree.name, "model": n.get("ssgi_model"),
           "pixels": np.unique(px.reshape(-1, 4), axis=0).tolist()}}, open({str(res)!r}, "w"))
''', timeout=300)
    r = json.loads(res.read_text())
    assert r["type"] == "CompositorNodeGroup" and r["tree"] == ".SSGI"
    assert r["model"] == str(room["model"])
    assert r["pixels"] == [[1.0, 0.0, 1.0, 1.0]]
    out = read_rgba(d / "noext.exr")
    assert np.isfinite(out).all()
    # Invert(magenta) + albedo: green plus albedo, never the old prediction
    assert np.all(out[..., 1] >= 1.0 - 1e-4)


def test_cli_renders_three_frames_each_its_own_prediction(room, tmp_path):
    p = run_cli("render", "--blend", str(room["blend"]), "--out", str(tmp_path / "anim_####"), "--frames", "1-3",
                "--save-passes", str(tmp_path / "passes"), "--temporal", "off", "--json", timeout=600)
    summary = json.loads(p.stdout)
    files = [tmp_path / f"anim_{f:04d}.exr" for f in (1, 2, 3)]
    assert summary["files"] == [str(f) for f in files]
    assert sorted(x.name for x in tmp_path.iterdir() if x.is_file()) == [f.name for f in files]
    from ssgi.model.dataset import exrio
    outs = []
    for f, path in zip((1, 2, 3), files):
        g = exrio.read_sample(tmp_path / "passes" / f"{f:06d}.exr", groups=("albedo", "normal", "depth", "direct", "eevee"))
        exp, _ = expected_image(room["model"], g, 100.0)
        got = read_rgba(path)
        np.testing.assert_allclose(got[..., :3], exp, rtol=1e-5, atol=1e-6, err_msg=f"frame {f}")
        outs.append(got)
    # the camera moves: each frame is its own
    assert np.abs(outs[0] - outs[1]).mean() > 1e-3 and np.abs(outs[1] - outs[2]).mean() > 1e-3


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_unknown_model_or_missing_passes_error_and_leave_scene_unchanged(room, tmp_path):
    blend = room["blend"]
    sha = _sha(blend)
    bad = tmp_path / "garbage.pt"
    bad.write_bytes(b"not a checkpoint")
    # command line: a clear message naming the file, exit 2, nothing written
    for model, words in ((tmp_path / "nope.pt", "no such model file"), (bad, "not an SSGI model checkpoint")):
        p = run_cli("render", "--blend", str(blend), "--out", str(tmp_path / "o_####"), "--model", str(model),
                    check=False, timeout=300)
        assert p.returncode == 2, clean(p.stderr)
        assert str(model) in p.stderr and words in p.stderr
        assert "Traceback" not in p.stderr
    assert not list(tmp_path.glob("o_*")) and _sha(blend) == sha
    # in Blender: operators report the error and change nothing (settings, passes, tree)
    res = tmp_path / "err.json"
    run_py(SCENE + SNAPSHOT + f'''
import json, ssgi
ssgi.register()
bpy.ops.wm.open_mainfile(filepath={str(blend)!r})
sc = bpy.context.scene
out = {{}}
before = settings_snapshot(sc)
for name, call in (("render_missing", lambda: bpy.ops.ssgi.render(model={str(tmp_path / "nope.pt")!r})),
                   ("setup_missing", lambda: bpy.ops.ssgi.setup(model={str(tmp_path / "nope.pt")!r}))):
    try:
        call(); out[name] = "no error"
    except RuntimeError as e:
        out[name] = str(e)
    out[name + "_unchanged"] = settings_snapshot(sc) == before
sc.view_layers[0].use_pass_diffuse_direct = False
before = settings_snapshot(sc)
try:
    bpy.ops.ssgi.render(); out["pass"] = "no error"
except RuntimeError as e:
    out["pass"] = str(e)
out["pass_unchanged"] = settings_snapshot(sc) == before
json.dump(out, open({str(res)!r}, "w"))
''', timeout=300)
    r = json.loads(res.read_text())
    for k in ("render_missing", "setup_missing"):
        assert "nope.pt" in r[k] and "no such model file" in r[k], r[k]
        assert r[k + "_unchanged"], k
    assert "Diffuse Direct (use_pass_diffuse_direct)" in r["pass"] and "Set up SSGI" in r["pass"], r["pass"]
    assert r["pass_unchanged"]


def test_setup_inserts_ssgi_keeping_the_artists_nodes(room, tmp_path):
    """Render Layers -> Glare -> Color Balance -> output becomes Render Layers -> SSGI -> Glare -> ...; passes
    on; a second Set up changes nothing; the Add menu and the render menu carry SSGI entries."""
    res = tmp_path / "setup.json"
    run_py(f'''
import bpy, json, ssgi
bpy.ops.wm.read_factory_settings(use_empty=True)
ssgi.register()
sc = bpy.context.scene
tree = bpy.data.node_groups.new("Artist", "CompositorNodeTree")
sc.compositing_node_group = tree
tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
rl = tree.nodes.new("CompositorNodeRLayers")
glare = tree.nodes.new("CompositorNodeGlare")
cb = tree.nodes.new("CompositorNodeColorBalance")
go = tree.nodes.new("NodeGroupOutput")
tree.links.new(rl.outputs["Image"], glare.inputs["Image"])
tree.links.new(glare.outputs["Image"], cb.inputs["Image"])
tree.links.new(cb.outputs["Image"], go.inputs[0])
bpy.ops.ssgi.setup(model={str(room["model"])!r})
links1 = sorted((l.from_node.name, l.to_node.name) for l in tree.links)
bpy.ops.ssgi.setup(model={str(room["model"])!r})
links2 = sorted((l.from_node.name, l.to_node.name) for l in tree.links)
vl = sc.view_layers[0]
from ssgi.ops import node_ops
from ssgi.panels import node_panel
from tests import ui_recorder
rec = ui_recorder.draw(node_panel.SSGI_PT_render)
json.dump({{"panel_ops": sorted(set(o for o, _ in rec.operators())), "panel_props": rec.props(),"links1": links1, "links2": links2, "n": len(tree.nodes),
           "passes": [vl.use_pass_diffuse_color, vl.use_pass_normal, vl.use_pass_z, vl.use_pass_diffuse_direct],
           "ao": vl.use_pass_ambient_occlusion,
           "add_menu": node_ops.draw_add_menu in bpy.types.NODE_MT_compositor_node_add_all._dyn_ui_initialize(),
           "render_menu": node_ops.draw_render_menu in bpy.types.TOPBAR_MT_render._dyn_ui_initialize(),
           "handler": node_ops.ssgi_render.on_render_pre in bpy.app.handlers.render_pre}}, open({str(res)!r}, "w"))
ssgi.unregister()
assert not hasattr(bpy.types.CompositorNodeGroup, "ssgi_model")
assert not hasattr(bpy.types.CompositorNodeGroup, "ssgi_model_choice")
assert not hasattr(bpy.types.CompositorNodeGroup, "ssgi_working_res")
assert not hasattr(bpy.types.CompositorNodeGroup, "ssgi_temporal")
assert node_ops.ssgi_render.on_render_pre not in bpy.app.handlers.render_pre
''', timeout=300)
    r = json.loads(res.read_text())
    want = sorted([["Render Layers", "SSGI"], ["SSGI", "Glare"], ["Glare", "Color Balance"],
                   ["Color Balance", "Group Output"]])
    assert r["links1"] == want and r["links2"] == want
    assert r["n"] == 5
    assert r["passes"] == [True, True, True, True] and r["ao"] is False
    assert r["add_menu"] and r["render_menu"] and r["handler"]
    assert r["panel_ops"] == ["ssgi.render", "ssgi.setup"] and r["panel_props"] == [
        "ssgi_model_choice", "ssgi_model", "ssgi_working_res", "ssgi_temporal"]  # a file set up: the menu's Custom


# ---------------------------------------------------------------- ops.TimerSteps: the modal loop of Bake and Render SSGI

_TIMER_STEPS = r'''
import json, types
import bpy
from ssgi.ops import TimerSteps
from ssgi.model.errors import UserError
held, log = {}, []

class SSGI_OT_test_steps(TimerSteps, bpy.types.Operator):
    bl_idname = "ssgi.test_steps"
    bl_label = "Test Steps"
    total: bpy.props.IntProperty(default=3)
    fail_at: bpy.props.IntProperty(default=-1)

    def execute(self, context):  # the bpy module runs execute for INVOKE_DEFAULT: start the loop here
        held["op"], self.done, self.stop = self, 0, False
        return self.start_steps(context, self.total)

    def step_work(self, context):
        if self.done == self.fail_at:
            raise UserError("unit failed")
        self.done += 1
        return self.done < self.total and not self.stop, self.done

    def stop_request(self):
        self.stop = True

    def steps_finished(self, context):
        log.append(["finished", self.done])

    def steps_failed(self, context, message):
        log.append(["failed", message])

bpy.utils.register_class(SSGI_OT_test_steps)
out = {}
for case, kw, events in (("run", {}, ["MOUSEMOVE", "TIMER", "TIMER", "TIMER"]),
                         ("esc", {"total": 5}, ["TIMER", "ESC"]),
                         ("fail", {"fail_at": 1}, ["TIMER", "TIMER"])):
    log.clear()
    r = [sorted(bpy.ops.ssgi.test_steps("INVOKE_DEFAULT", **kw))]
    op = held["op"]
    for kind in events:
        timer = op._timer
        try:
            # a stand-in for the event (bpy cannot make one); the operator, context and timer are real
            r.append(sorted(op.modal(bpy.context, types.SimpleNamespace(type=kind, timer=timer))))
        except RuntimeError as e:  # the ERROR report raises in the bpy module
            r.append(["raised", str(e)])
    r.append(["timer_removed", op._timer is None])
    out[case] = [r, list(log)]
bpy.utils.unregister_class(SSGI_OT_test_steps)
print("JSON" + json.dumps(out))
'''


def test_timer_steps_loop_finishes_stops_on_esc_and_cleans_up_after_an_error():
    """ops.TimerSteps (shared by Bake Dataset and Render SSGI), driven with timer and Esc events by hand: the bpy
    module has no event loop, and runs execute for INVOKE_DEFAULT, so the test operator starts its loop there."""
    p = run_py(_TIMER_STEPS, timeout=300)
    r = json.loads(p.stdout.split("JSON", 1)[1])
    assert r["run"] == [[["RUNNING_MODAL"], ["PASS_THROUGH"], ["RUNNING_MODAL"], ["RUNNING_MODAL"], ["FINISHED"],
                         ["timer_removed", True]], [["finished", 3]]]
    assert r["esc"] == [[["RUNNING_MODAL"], ["RUNNING_MODAL"], ["FINISHED"], ["timer_removed", True]], [["finished", 2]]]
    assert r["fail"] == [[["RUNNING_MODAL"], ["RUNNING_MODAL"], ["CANCELLED"], ["timer_removed", True]],
                         [["failed", "unit failed"]]]


# ---------------------------------------------------------------- the scene's model setting (scene.ssgi.model_path)

_SCENE_MODEL = r'''
import json, sys
from pathlib import Path
import bpy
import ssgi
from ssgi.ssgi_addon.blender import node
d = Path(sys.argv[1])
bpy.ops.wm.read_factory_settings(use_empty=True)
ssgi.register()
sc = bpy.context.scene
out = {"default": str(node.resolve_model(sc))}
sc.ssgi.model_path = str(d / "scene_model.pt")  # as the SSGI panel's Model field sets it
out["registered"] = str(node.resolve_model(sc))
out["override"] = str(node.resolve_model(sc, str(d / "other.pt")))
bpy.ops.wm.save_as_mainfile(filepath=str(d / "set.blend"))
ssgi.unregister()
# the same file without the add-on: the stored setting is still the scene's model
bpy.ops.wm.open_mainfile(filepath=str(d / "set.blend"))
out["unregistered_reopened"] = str(node.resolve_model(bpy.context.scene))
# a scene whose setting is a plain ID property (a script's scene["ssgi"] = {...}), add-on not registered
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.scene["ssgi"] = {"model_path": str(d / "id_prop.pt")}
out["id_property"] = str(node.resolve_model(bpy.context.scene))
print("JSON" + json.dumps(out))
'''


def test_resolve_model_uses_the_scene_model_set_in_the_ui(tmp_path):
    """scene.ssgi.model_path, set with the add-on registered, is the model when no node names one; it still is
    in a reopened file without the add-on, and a plain ID property scene["ssgi"] works too."""
    from ssgi.ssgi_addon.blender.node import DEFAULT_MODEL
    r = json.loads(run_py(_SCENE_MODEL, str(tmp_path), timeout=300).stdout.split("JSON", 1)[1])
    assert r["default"] == str(DEFAULT_MODEL)
    assert r["registered"] == str(tmp_path / "scene_model.pt")
    assert r["override"] == str(tmp_path / "other.pt")
    assert r["unregistered_reopened"] == str(tmp_path / "scene_model.pt")
    assert r["id_property"] == str(tmp_path / "id_prop.pt")
