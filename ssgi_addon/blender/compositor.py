"""The scene's compositor and SSGI: "Set up SSGI" (``setup_scene``: enable the passes the model needs, wire
Render Layers -> SSGI -> the output, keeping the artist's nodes after it) and the composite-only pass of the
render path (``standins``: the tree's Render Layers nodes muted and fed from Image nodes showing the pass
render's multilayer EXR, saved by ``save_multilayer``). The operator, ``cli.py render --setup`` and the demo
all call ``setup_scene``."""
from __future__ import annotations

import contextlib

import bpy

from ...model import channels as ch
from . import node as ssgi_node
from .predictor import load_model
from .scene_state import _restore, _snapshot


def setup_scene(scene, model: str | None = None) -> dict:
    """Set up SSGI: check the model, enable the passes it needs on the first view layer, wire Render Layers ->
    SSGI -> the output keeping the artist's nodes after it. The model is checked before anything changes."""
    path = ssgi_node.resolve_model(scene, model)
    pred = load_model(path)
    vl = scene.view_layers[0]
    enabled = []
    for flag in ch.required_passes(tuple(pred.spec)):
        if not getattr(vl, flag):
            setattr(vl, flag, True)
            enabled.append(flag)
    tree, node, rl = wire(scene, vl)
    if model:
        node[ssgi_node.MODEL_PROP] = model
    scene.render.use_compositing = True
    scene[ssgi_node.SHOT_START] = int(scene.frame_start)  # the shot's first frame for farm workers (pipeline/farm.py)
    return {"tree": tree.name, "node": node.name, "enabled_passes": enabled, "model": str(path)}


def ensure_compositor(scene):
    """The scene's compositor tree; a new one (Render Layers -> Group Output) when it has none."""
    tree = scene.compositing_node_group
    if tree is None:
        tree = bpy.data.node_groups.new(f"{scene.name} Compositing", "CompositorNodeTree")
        scene.compositing_node_group = tree
    if not any(s.in_out == "OUTPUT" for s in tree.interface.items_tree if getattr(s, "item_type", "") == "SOCKET"):
        tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    return tree


def _group_output(tree):
    outs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
    for n in outs:
        if n.is_active_output:
            return n
    return outs[0] if outs else None


def render_layers(tree, view_layer=None):
    """The tree's Render Layers node of ``view_layer`` (any, when None), added at the left when there is none."""
    rl = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"
               and (view_layer is None or n.layer == view_layer.name)), None)
    if rl is None:
        rl = tree.nodes.new("CompositorNodeRLayers")
        rl.location = (-500, 0)
        if view_layer is not None:
            rl.layer = view_layer.name
    return rl


def feed_output(tree, node) -> None:
    """Link ``node``'s first output to the tree's group output (added right of ``node`` when there is none), unless
    something feeds that output already."""
    gout = _group_output(tree)
    if gout is None:
        gout = tree.nodes.new("NodeGroupOutput")
        gout.location = (node.location.x + 300, node.location.y)
    if not gout.inputs[0].is_linked:
        tree.links.new(node.outputs[0], gout.inputs[0])


def wire(scene, view_layer=None):
    """Insert an SSGI node after Render Layers in the scene's compositor, keeping the artist's nodes after
    it: every link that leaves Render Layers' Image now leaves SSGI's output. Idempotent: an existing SSGI
    node is reused. Returns (tree, ssgi_node, render_layers_node)."""
    tree = ensure_compositor(scene)
    rl = render_layers(tree, view_layer)
    existing = ssgi_node.ssgi_nodes(tree)
    if existing:
        node = existing[0]
        if not node.inputs[0].is_linked:
            tree.links.new(rl.outputs["Image"], node.inputs[0])
        return tree, node, rl
    node = ssgi_node.new_node(tree, (rl.location.x + 300, rl.location.y))
    # move the artist's nodes right to make room (layout only)
    for n in tree.nodes:
        if n not in (rl, node) and n.location.x > rl.location.x and n.parent is None:
            n.location.x += 250
    consumers = [l.to_socket for l in tree.links if l.from_node == rl and l.from_socket.name == "Image"]
    tree.links.new(rl.outputs["Image"], node.inputs[0])
    for sock in consumers:
        tree.links.new(node.outputs[0], sock)
    if not consumers:
        feed_output(tree, node)
    return tree, node, rl


# --- the composite-only pass ----------------------------------------------------------------------------

def _standin_socket(rl_socket_name: str) -> str:
    return "Combined" if rl_socket_name == "Image" else rl_socket_name


@contextlib.contextmanager
def standins(scene, exr_path: str | None):
    """Mute the compositor's Render Layers nodes (so the render is composite-only) and feed their links from
    Image nodes showing the pass render's multilayer EXR; put the tree back on exit."""
    tree = scene.compositing_node_group
    rls = [n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers" and not n.mute]
    saved_links = [(l.from_node.name, l.from_socket.identifier, l.to_node.name, l.to_socket.identifier)
                   for l in tree.links if l.from_node in rls]
    added, image = [], None
    try:
        if exr_path and rls:
            image = bpy.data.images.load(exr_path, check_existing=False)
            image.name = ".SSGI passes"
        for rl in rls:
            rl.mute = True
            if image is None:
                continue
            st = tree.nodes.new("CompositorNodeImage")
            added.append(st)
            st.image = image
            st.location = (rl.location.x, rl.location.y - 400)
            try:
                st.layer = rl.layer
            except TypeError:
                pass
            for l in [l for l in tree.links if l.from_node == rl]:
                out = st.outputs.get(_standin_socket(l.from_socket.name))
                if out is not None:
                    tree.links.new(out, l.to_socket)
        yield
    finally:
        for st in added:
            tree.nodes.remove(st)
        for rl in rls:
            rl.mute = False
        for fn, fs, tn, ts in saved_links:
            a, b = tree.nodes.get(fn), tree.nodes.get(tn)
            if a is None or b is None:
                continue
            fsock = next((s for s in a.outputs if s.identifier == fs), None)
            tsock = next((s for s in b.inputs if s.identifier == ts), None)
            if fsock is not None and tsock is not None and not any(
                    l.from_socket == fsock and l.to_socket == tsock for l in tree.links):
                tree.links.new(fsock, tsock)
        if image is not None:
            bpy.data.images.remove(image)


def save_multilayer(scene, path: str) -> None:
    """Save the current Render Result (all passes, 32-bit) as a multilayer EXR; output settings put back."""
    ims = scene.render.image_settings
    saved = _snapshot(ims)
    try:
        ims.media_type = "MULTI_LAYER_IMAGE"
        ims.file_format = "OPEN_EXR_MULTILAYER"
        ims.color_depth = "32"
        bpy.data.images["Render Result"].save_render(path, scene=scene)
    finally:
        _restore(ims, saved)
        _restore(ims, saved)
