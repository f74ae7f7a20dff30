"""The "SSGI" compositor node: a plain ``CompositorNodeGroup`` whose inner tree the extension builds.

Why a plain group and not a Python ``CompositorNodeCustomGroup``: a .blend saved with a custom group node
opens as ``NodeUndefined`` on a Blender without the extension, and a composite-only render of it
segfaulted (shared/blender5-notes.md). A plain group reopens and renders anywhere. Python cannot run
per-pixel code in the compositor, so the prediction reaches the tree as a float image:

    SSGI node (group ".SSGI")                       inputs: Image (EEVEE render, gives the alpha)
      Image node  -> image "SSGI Prediction"  --\
      Group Input.Image -> Separate Color.Alpha --> Set Alpha (Replace Alpha) -> Group Output.Image

The render path (render.py) fills "SSGI Prediction" with the prediction of the frame being rendered, then
runs a composite-only render so the artist's nodes after SSGI apply. Outside that path the image holds a
magenta PLACEHOLDER: a generated image's pixels are not saved in the .blend, so a reopened file (with or
without the extension) regenerates it from ``generated_color``; and with the extension present, a
``render_pre`` handler puts the placeholder back before any other render and prints a warning, so a plain
F12 / ``blender -b file.blend -f 1`` never shows a stale prediction. The image's custom properties stamp
what it holds (``ssgi_state`` = "prediction"/"placeholder", scene, frame, model).

The node's setting (the model file) is the string ID property ``ssgi_model`` on the group node; the add-on
registers it as an RNA property of ``CompositorNodeGroup`` so it can be drawn, and without the add-on it
stays in the file as a plain ID property. Empty means the scene's model (``scene.ssgi.model_path``) or the
shipped default model. The second setting, ``ssgi_working_res`` (same mechanism), is the resolution the
network predicts at (model/infer/workres.py: "auto", "full", "4x", "480x270"; missing or empty: "auto").
"""
from __future__ import annotations

from pathlib import Path

import bpy

from ...model import shipped

INNER_TREE = ".SSGI"
IMAGE_NAME = "SSGI Prediction"
NODE_LABEL = "SSGI"
MARKER = "ssgi_node"  # ID property on the inner tree: the layout version below
TREE_VERSION = 1
MODEL_PROP = "ssgi_model"
# scene ID property: the scene's frame start when the file was last saved or set up (pipeline/farm.py: a farm worker's
# -s overwrites frame_start, and the temporal mode blends nothing before the shot's first frame)
SHOT_START = "ssgi_shot_start"
WORKRES_PROP = "ssgi_working_res"  # "auto" | "full" | "Nx" | "WxH" (model/infer/workres.py)
PLACEHOLDER = (1.0, 0.0, 1.0, 1.0)  # magenta: "this is not a prediction"
NOTE = "SSGI: shows a magenta placeholder unless rendered with Render SSGI (bpy.ops.ssgi.render / cli.py render)"
DEFAULT_MODEL = shipped.DEFAULT.path


# --- the inner tree and its image -------------------------------------------------------------------

def is_ssgi_tree(tree) -> bool:
    return tree is not None and bool(tree.get(MARKER))


def is_ssgi_node(node) -> bool:
    return node.bl_idname == "CompositorNodeGroup" and is_ssgi_tree(getattr(node, "node_tree", None))


def ssgi_nodes(tree) -> list:
    """SSGI group nodes in ``tree`` (top level; the node is meant to sit in the scene's compositor)."""
    return [n for n in tree.nodes if is_ssgi_node(n)] if tree is not None else []


def is_set_up(scene) -> bool:
    """Whether ``scene`` renders through an SSGI node: one in its compositor, and the compositor on."""
    return bool(ssgi_nodes(scene.compositing_node_group)) and scene.render.use_compositing


def ensure_image(width: int = 16, height: int = 16):
    """The float image datablock the render path fills; made (magenta placeholder) when missing."""
    img = bpy.data.images.get(IMAGE_NAME)
    if img is None or img.source != "GENERATED":
        if img is not None:  # someone replaced it with a file image: make our own again
            img.name = IMAGE_NAME + ".old"
        img = bpy.data.images.new(IMAGE_NAME, width, height, alpha=True, float_buffer=True)
        img.generated_color = PLACEHOLDER
        img["ssgi_state"] = "placeholder"
    img.alpha_mode = "STRAIGHT"  # we always write alpha = 1; the node takes alpha from its input
    return img


def ensure_inner_tree():
    """The ".SSGI" node tree, built (or rebuilt when its layout version is older) by the extension."""
    tree = bpy.data.node_groups.get(INNER_TREE)
    if tree is not None and tree.bl_idname == "CompositorNodeTree" and tree.get(MARKER) == TREE_VERSION:
        return tree
    if tree is None or tree.bl_idname != "CompositorNodeTree":
        tree = bpy.data.node_groups.new(INNER_TREE, "CompositorNodeTree")
    _build_inner(tree)
    return tree


def _build_inner(tree) -> None:
    tree.nodes.clear()
    tree.interface.clear()
    tree.interface.new_socket("Image", in_out="INPUT", socket_type="NodeSocketColor",
                              description="The EEVEE render (Render Layers > Image): SSGI keeps its alpha")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor",
                              description="Predicted global illumination, linear scene-referred")
    gin = tree.nodes.new("NodeGroupInput")
    gin.location = (-500, -200)
    img_node = tree.nodes.new("CompositorNodeImage")
    img_node.name = img_node.label = "SSGI Prediction"
    img_node.image = ensure_image()
    img_node.location = (-300, 100)
    sep = tree.nodes.new("CompositorNodeSeparateColor")
    sep.location = (-300, -200)
    setalpha = tree.nodes.new("CompositorNodeSetAlpha")
    setalpha.inputs["Type"].default_value = "Replace Alpha"
    setalpha.location = (-50, 0)
    gout = tree.nodes.new("NodeGroupOutput")
    gout.location = (200, 0)
    tree.links.new(img_node.outputs["Image"], setalpha.inputs["Image"])
    tree.links.new(gin.outputs[0], sep.inputs[0])
    tree.links.new(sep.outputs["Alpha"], setalpha.inputs["Alpha"])
    tree.links.new(setalpha.outputs[0], gout.inputs[0])
    frame = tree.nodes.new("NodeFrame")
    frame.name = "SSGI note"
    frame.label = NOTE
    frame.location = (-520, 260)
    frame.width, frame.height = 900, 60
    tree[MARKER] = TREE_VERSION
    tree.use_fake_user = False


def new_node(tree, location=(0.0, 0.0)):
    """Add an SSGI group node to the compositor tree ``tree``."""
    node = tree.nodes.new("CompositorNodeGroup")
    node.node_tree = ensure_inner_tree()
    node.name = node.label = NODE_LABEL
    node.location = location
    node.width = 180
    node[MODEL_PROP] = node.get(MODEL_PROP, "")
    return node


# --- the model setting --------------------------------------------------------------------------------

def node_model(node) -> str:
    return str(node.get(MODEL_PROP, "") or "")


def scene_model(scene) -> str:
    """The scene's model setting ``scene.ssgi.model_path`` ("" when unset).

    With the add-on registered it is the registered property. Where it is not (a file reopened without it),
    Blender 5.0 keeps a registered property's value among the ID's *system* properties
    (``bl_system_properties_get()``), not in ``scene.get("ssgi")``, which is None for it; a plain ID property
    ``scene["ssgi"] = {"model_path": ...}`` (set by a script) is read last."""
    settings = getattr(scene, "ssgi", None)
    if settings is not None and hasattr(settings, "model_path"):
        return str(settings.model_path or "")
    getter = getattr(scene, "bl_system_properties_get", None)
    for grp in ((getter() if getter is not None else None), scene):
        try:
            sub = grp.get("ssgi") if grp is not None else None
            path = sub.get("model_path", "") if sub is not None else ""
        except (AttributeError, TypeError):
            continue
        if path:
            return str(path)
    return ""


def resolve_model(scene, override: str | None = None) -> Path:
    """The model file to use: ``override``, else the first SSGI node's setting, else the scene's, else the
    shipped default. A setting may name a shipped model (model/shipped.py). Relative Blender paths (``//``) are
    made absolute. Does not check existence."""
    cand = override or ""
    if not cand:
        for n in ssgi_nodes(scene.compositing_node_group):
            if node_model(n):
                cand = node_model(n)
                break
    cand = cand or scene_model(scene)
    named = shipped.resolve(cand) if not cand or cand.strip() in shipped.BY_NAME else None  # "" or a shipped name
    if named is not None:
        return named
    return Path(bpy.path.abspath(cand)).expanduser()


def node_working_res(node) -> str:
    return str(node.get(WORKRES_PROP, "") or "")


def resolve_working_res(scene, override: str | None = None) -> str:
    """The working-resolution setting: ``override``, else the first SSGI node's that has one, else "auto"."""
    if override:
        return str(override)
    for n in ssgi_nodes(scene.compositing_node_group):
        if node_working_res(n):
            return node_working_res(n)
    from ...model.infer.workres import AUTO
    return AUTO


# --- the prediction image -----------------------------------------------------------------------------

def _resize(img, w: int, h: int) -> None:
    """Resize through the generated size (not ``scale``): a reopened file regenerates the placeholder at the
    generated size, which must cover the whole frame."""
    if (img.generated_width, img.generated_height) != (w, h):
        img.generated_width, img.generated_height = w, h
    if tuple(img.size) != (w, h):
        img.scale(w, h)


def set_prediction(rgb, scene, frame: int, model: str):
    """Put a HxWx3 linear prediction (top row first) into the image and stamp what it is."""
    import numpy as np

    h, w = rgb.shape[:2]
    img = ensure_image(w, h)
    _resize(img, w, h)
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[..., :3] = rgb
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    img.update()
    img["ssgi_state"] = "prediction"
    img["ssgi_scene"] = scene.name
    img["ssgi_frame"] = int(frame)
    img["ssgi_model"] = str(model)
    return img


def set_placeholder(width: int | None = None, height: int | None = None):
    """Fill the image with the magenta placeholder and stamp it so."""
    import numpy as np

    img = ensure_image(width or 16, height or 16)
    if width and height:
        _resize(img, width, height)
    n = img.size[0] * img.size[1]
    img.pixels.foreach_set(np.tile(np.asarray(PLACEHOLDER, np.float32), n))
    img.update()
    img["ssgi_state"] = "placeholder"
    for k in ("ssgi_scene", "ssgi_frame", "ssgi_model"):
        if k in img:
            del img[k]
    return img


def image_state(scene=None) -> dict:
    """What the prediction image holds, for panels: {state, scene, frame, model, current}."""
    img = bpy.data.images.get(IMAGE_NAME)
    if img is None:
        return {"state": "missing", "current": False}
    d = {k[5:]: img.get(k) for k in ("ssgi_state", "ssgi_scene", "ssgi_frame", "ssgi_model")}
    d["current"] = bool(scene is not None and d["state"] == "prediction" and d["scene"] == scene.name
                        and d["frame"] == scene.frame_current)
    return d
