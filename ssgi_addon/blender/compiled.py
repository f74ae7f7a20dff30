"""SSGI as Blender's own compositor nodes: a compiled model (model/compile/graph.py) becomes one plain
``CompositorNodeGroup`` between Render Layers and the output, so that a plain render (F12, ``bpy.ops.render.render``,
``blender -b file.blend -a``) shows SSGI without the extension (docs/compiled.md).

``setup_compiled(scene, model)`` (Set up SSGI's compiled choice and ``cli.py setup --compiled``) makes the scene's
own render the frame the network reads (EEVEE, ray tracing and fast GI off, no lamp culled, the emitter proxies as
area lights, the Diffuse Color and Normal passes on: the one render of docs/one_render.md), builds the group and
stores the per-frame constants in it: the camera's rotation, driven from the scene's camera by drivers of simple
expressions (no Python at render time), and the world's light coefficients. Each graph step is one or a few nodes: vector math for per-pixel work (fused
by the compositor), math nodes for log and exp per channel, Translate (nearest, zeros outside) for shifts. A node
is evaluated on the pixel grid of its first input, and the graph never puts a shifted value first.
"""
from __future__ import annotations

import math

import bpy
import numpy as np

from ...model.compile import graph as cgraph

GROUP_NAME = "SSGI compiled"
LAYOUT_PROP = "ssgi_compiled"  # ID property of the inner tree: the layout version
LAYOUT_VERSION = 1
PARAM_NODE = "param {}"


# A plain render of a file, for checks and measurements of a compiled set-up: ``python -c PLAIN_RENDER FILE OUT
# [FIRST LAST]`` opens FILE in bpy (nothing of SSGI imported) and renders OUT (a still; with FIRST LAST the frames,
# '#' in OUT for the frame number) as 32-bit RGBA OpenEXR; it prints a RESULT line saying whether any SSGI module was
# loaded and which add-ons were enabled.
PLAIN_RENDER = """
import sys, json, bpy
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
sc = bpy.context.scene
ims = sc.render.image_settings
ims.media_type, ims.file_format, ims.color_depth, ims.color_mode = "IMAGE", "OPEN_EXR", "32", "RGBA"
sc.render.filepath = sys.argv[2]
if len(sys.argv) > 3:
    sc.frame_start, sc.frame_end = int(sys.argv[3]), int(sys.argv[4])
    bpy.ops.render.render(animation=True)
else:
    bpy.ops.render.render(write_still=True)
print("RESULT", json.dumps({"ssgi_loaded": any("ssgi" in m for m in sys.modules),
                            "addons": sorted(bpy.context.preferences.addons.keys())}))
"""


class _Lower:
    """Graph values -> node sockets. A value is a list of (vector socket, channels), three channels a socket."""

    def __init__(self, tree):
        self.t = tree
        self.x = 0
        self.y = 0

    def node(self, kind: str, **props):
        n = self.t.nodes.new(kind)
        n.location = (self.x, self.y)
        self.y -= 160
        for k, v in props.items():
            setattr(n, k, v)
        return n

    def put(self, sock, v) -> None:
        if isinstance(v, (int, float, np.floating)):
            sock.default_value = (float(v),) * 3 if sock.type == "VECTOR" else float(v)
        elif isinstance(v, (tuple, list, np.ndarray)):
            sock.default_value = tuple(float(a) for a in v)
        else:
            self.t.links.new(v, sock)

    def vmath(self, op: str, *args):
        n = self.node("ShaderNodeVectorMath", operation=op)
        for i, a in enumerate(args):
            self.put(n.inputs[i], a)
        return n.outputs["Value"] if op == "LENGTH" else n.outputs["Vector"]

    def math(self, op: str, *args):
        n = self.node("ShaderNodeMath", operation=op)
        for i, a in enumerate(args):
            self.put(n.inputs[i], a)
        return n.outputs[0]

    def scalars(self, value) -> list:
        out = []
        for sock, nch in value:
            sep = self.node("ShaderNodeSeparateXYZ")
            self.t.links.new(sock, sep.inputs[0])
            out += [sep.outputs[i] for i in range(nch)]
        return out

    def per_channel(self, value, fn) -> list:
        out = []
        for sock, nch in value:
            ch = self.scalars([(sock, nch)])
            comb = self.node("ShaderNodeCombineXYZ")
            for i, s in enumerate(ch):
                self.t.links.new(fn(s), comb.inputs[i])
            out.append((comb.outputs[0], nch))
        return out


def build_group(graph: cgraph.Graph, params: dict, name: str = GROUP_NAME):
    """A new compositor node tree computing ``graph``: inputs Image, Diffuse Color, Normal (Render Layers'),
    output Image (the SSGI frame, with the Image input's alpha)."""
    tree = bpy.data.node_groups.new(name, "CompositorNodeTree")
    tree[LAYOUT_PROP] = LAYOUT_VERSION
    for sock_name, kind in (("Image", "NodeSocketColor"), ("Diffuse Color", "NodeSocketColor"),
                            ("Normal", "NodeSocketVector")):
        tree.interface.new_socket(sock_name, in_out="INPUT", socket_type=kind)
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    lw = _Lower(tree)
    gin = lw.node("NodeGroupInput")
    v: dict[str, list] = {}
    for op in graph.ops:
        lw.x += 220
        lw.y = 0
        a = op.args

        def val(x):
            return v[x] if isinstance(x, str) else [(float(x), 3)]

        if op.op == "input":
            r = [(gin.outputs[cgraph.PASSES[a[0]]], 3)]
        elif op.op == "param":
            n = lw.node("ShaderNodeCombineXYZ", name=PARAM_NODE.format(a[0]), label=a[0])
            r = [(n.outputs[0], 3)]
        elif op.op == "clamp":
            r = [(lw.vmath("MINIMUM", lw.vmath("MAXIMUM", s, a[1]), a[2]), c) for s, c in v[a[0]]]
        elif op.op == "log1p":
            r = lw.per_channel(v[a[0]], lambda s: lw.math("LOGARITHM", lw.math("ADD", s, 1.0), math.e))
        elif op.op == "expm1":
            r = lw.per_channel(v[a[0]], lambda s: lw.math("SUBTRACT", lw.math("EXPONENT", s), 1.0))
        elif op.op == "shift":
            r = []
            for s, c in v[a[0]]:
                n = lw.node("CompositorNodeTranslate")
                tree.links.new(s, n.inputs["Image"])
                n.inputs["X"].default_value, n.inputs["Y"].default_value = float(a[1]), float(a[2])
                n.inputs["Interpolation"].default_value = "Nearest"
                r.append((n.outputs[0], c))
        elif op.op in ("add", "sub", "mul", "div", "max"):
            vop = {"add": "ADD", "sub": "SUBTRACT", "mul": "MULTIPLY", "div": "DIVIDE", "max": "MAXIMUM"}[op.op]
            bs = val(a[1])
            r = [(lw.vmath(vop, s, bs[min(i, len(bs) - 1)][0]), c) for i, (s, c) in enumerate(v[a[0]])]
        elif op.op == "lincomb":
            xs = lw.scalars(v[a[0]])
            acc = v[op.kw["bias"]][0][0] if op.kw.get("bias") else (0.0, 0.0, 0.0)
            for s, p in zip(xs, a[1:]):
                acc = lw.vmath("MULTIPLY_ADD", s, v[p][0][0], acc)
            r = [(acc, 3)]
        elif op.op == "masklen":
            hit = lw.math("GREATER_THAN", lw.vmath("LENGTH", v[a[1]][0][0]), float(a[2]))
            r = [(lw.vmath("MULTIPLY", s, hit), c) for s, c in v[a[0]]]
        elif op.op == "affine":
            xs = lw.scalars([sc for src in a for sc in v[src]])
            w, b = op.kw["W"], op.kw["b"]
            r = []
            for j in range(0, w.shape[0], 3):
                wj = np.zeros((3, w.shape[1]), np.float32)
                wj[:min(3, w.shape[0] - j)] = w[j:j + 3]
                bj = np.zeros(3, np.float32)
                bj[:min(3, w.shape[0] - j)] = b[j:j + 3]
                acc = tuple(bj)
                for i, s in enumerate(xs):
                    acc = lw.vmath("MULTIPLY_ADD", s, tuple(wj[:, i]), acc)
                r.append((acc, min(3, w.shape[0] - j)))
        elif op.op == "relu":
            r = [(lw.vmath("MAXIMUM", s, 0.0), c) for s, c in v[a[0]]]
        else:
            raise ValueError(f"unknown operation {op.op!r}")
        v[op.out] = r
    lw.x += 220
    alpha = lw.node("CompositorNodeSeparateColor")
    tree.links.new(gin.outputs["Image"], alpha.inputs[0])
    seta = lw.node("CompositorNodeSetAlpha")
    tree.links.new(v[graph.output][0][0], seta.inputs["Image"])
    tree.links.new(alpha.outputs["Alpha"], seta.inputs["Alpha"])
    seta.inputs["Type"].default_value = "Replace Alpha"
    lw.x += 220
    gout = lw.node("NodeGroupOutput")
    tree.links.new(seta.outputs[0], gout.inputs[0])
    set_params(tree, params)
    return tree


def set_params(tree, params: dict) -> None:
    """Store the per-frame constants in the group's param nodes (the camera's are driven: ``drive_camera``)."""
    for name, value in params.items():
        n = tree.nodes.get(PARAM_NODE.format(name))
        if n is None:
            continue
        for i in range(3):
            n.inputs[i].default_value = float(value[i])


def frame_params(scene) -> dict:
    """The graph's per-frame constants at the scene's current frame (camera rotation, the world's light)."""
    from . import passes, sky

    return cgraph.frame_params(passes.camera_rotation(scene), sky.world_coefficients(scene.world))


def render_width(scene) -> int:
    return max(1, int(scene.render.resolution_x * scene.render.resolution_percentage / 100))


def one_render_settings(scene, proxies: dict | None = None) -> dict:
    """Make the scene's own render the frame a compiled model reads (persistent): EEVEE, ray tracing and fast GI off,
    no lamp culled, the emitter proxies as lights of the file (``proxies``: the model's, passes.recorded_proxy_options;
    else passes.ONE_RENDER_SETTINGS'), the Diffuse Color and Normal passes on, and EEVEE's shadows off where nothing
    can cast one (the same image)."""
    from . import direct_light, passes

    opts = {k: v for k, v in (proxies or {}).items() if v is not None}
    one = passes.ONE_RENDER_SETTINGS

    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.use_raytracing = scene.eevee.use_fast_gi = False
    passes.no_light_culled(scene)
    made = []
    if not any(o.name.startswith("ssgi_proxy_") for o in scene.objects):
        direct_light.make_proxies(scene, opts.get("proxy_shadows", one["proxy_shadows"]),
                                  opts.get("proxy_sides", one["proxy_sides"]), made,
                                  opts.get("proxy_shapes", one["proxy_shapes"]))
    vl = scene.view_layers[0]
    vl.use_pass_diffuse_color = vl.use_pass_normal = True
    if passes.casts_no_shadow(scene):
        scene.eevee.use_shadows = False
    return {"proxies": [o.name for o in made], "shadows": bool(scene.eevee.use_shadows)}


def _wire(scene, group):
    """Render Layers -> the compiled group -> whatever read Render Layers' Image (else the group output)."""
    from .compositor import ensure_compositor, feed_output, render_layers

    tree = ensure_compositor(scene)
    rl = render_layers(tree, scene.view_layers[0])
    node = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeGroup" and n.node_tree is not None
                 and LAYOUT_PROP in n.node_tree), None)
    consumers = []
    if node is None:
        node = tree.nodes.new("CompositorNodeGroup")
        node.location = (rl.location.x + 300, rl.location.y)
        consumers = [l.to_socket for l in tree.links if l.from_node == rl and l.from_socket.name == "Image"]
    node.node_tree, node.name, node.label = group, GROUP_NAME, GROUP_NAME
    for name in ("Image", "Diffuse Color", "Normal"):
        tree.links.new(rl.outputs[name], node.inputs[name])
    for sock in consumers:
        tree.links.new(node.outputs[0], sock)
    feed_output(tree, node)
    return tree, node


def setup_compiled(scene, model) -> dict:
    """Set up SSGI as compositor nodes: check and compile ``model`` (a boxmlp checkpoint) first (a bad model changes
    nothing), then the one-render settings, the group wired after Render Layers, its per-frame constants."""
    from ...model.learn import checkpoint
    from . import passes

    passes._check_camera(scene)
    ckpt = checkpoint.load(model)
    width = render_width(scene)
    graph = cgraph.from_checkpoint(ckpt, width, path=model)
    settings = one_render_settings(scene, passes.recorded_proxy_options(ckpt))
    old = next((n.node_tree for n in (scene.compositing_node_group.nodes if scene.compositing_node_group else ())
                if n.bl_idname == "CompositorNodeGroup" and n.node_tree is not None and LAYOUT_PROP in n.node_tree), None)
    group = build_group(graph, frame_params(scene))
    group["ssgi_model"] = str(model)
    group["ssgi_width"] = width
    tree, node = _wire(scene, group)
    if old is not None and old.users == 0:
        bpy.data.node_groups.remove(old)
    drivers = drive_camera(scene, group)
    scene.render.use_compositing = True
    # the viewport compositor works in half floats unless told otherwise (F12 always in full): exp and log of light
    # need full
    scene.render.compositor_precision = "FULL"
    return {"tree": tree.name, "node": node.name, "group": group.name, "nodes": len(group.nodes), "width": width,
            "camera_drivers": drivers, "model": str(model), **settings,
            "ops": {k: graph.count(k) for k in ("shift", "affine", "log1p")}}


def drive_camera(scene, group) -> int:
    """Drive the group's camera rotation (``param rot0..2``) from the scene's camera: each value is a driver of simple
    expression (evaluated without Python, so a file from elsewhere renders it with scripts disabled) reading
    ``scene.camera.matrix_world``, its column normalised (passes.camera_rotation). It follows the camera's animation,
    edits made after set-up and cameras switched by markers. Returns the drivers made."""
    made = 0
    for i in range(3):
        node = group.nodes[PARAM_NODE.format(f"rot{i}")]
        for j in range(3):
            d = node.inputs[j].driver_add("default_value").driver
            d.type = "SCRIPTED"
            for k, name in enumerate("abc"):
                v = d.variables.new()
                v.name, v.type = name, "SINGLE_PROP"
                v.targets[0].id_type = "SCENE"
                v.targets[0].id = scene
                v.targets[0].data_path = f"camera.matrix_world[{j}][{k}]"  # (RNA stores it column by column)
            d.expression = f"{'abc'[i]} / sqrt(a * a + b * b + c * c)"
            made += 1
    return made
