"""Bad input: what each scene setup that the SSGI path cannot handle does to the image, measured
through the real render path (setup_scene + RenderSession, real EEVEE) on the tiny emissive/metal/glass/glossy
scene (artist_scenes.tiny_material_scene) with a random diffuse-part model (unet_s, target ref_diffuse).

    .venv/bin/python benchmarks/bad_input.py --out DIR [--size 64x36] [--samples 4] [--cases baseline holdout_object ...]

Per case (``CASES``: a function that changes the tiny scene) it prints one JSON line: what RenderSession did
(``status``: "ok", or the UserError's text; ``warnings``: the summary's), the written frame's alpha and RGB means
over the whole image and over the case's object, EEVEE's own render there (``beauty``: Combined at the artist's
settings), and ``direct_only``: albedo x direct (the G-buffer) + rest, what a model that predicted EEVEE's direct
diffuse light exactly would show (independent of the random model). It writes DIR/CASE.png: EEVEE's own render |
the SSGI frame | direct_only, side by side. The scene checks (scene_checks.check_scene) are skipped
(``RenderSession(checks=False)``), so that a refused case is measured too; --checks keeps them.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import _bootstrap  # noqa: F401,E402  (the checkout as package ssgi)
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

from scenes import artist as artist_scenes  # noqa: E402


def make_model(path, target="ref_diffuse", spec="albedo,normal,depth,direct,emission,lit", seed=0) -> str:
    """A random (untrained) unet_s checkpoint of ``target`` at ``path``."""
    import torch
    from ssgi.model.learn import checkpoint, network
    torch.manual_seed(seed)
    net = network.build(network.arch_for("unet_s", spec, target=target))
    checkpoint.save(str(path), checkpoint.make(net, "network"))
    return str(path)


# --- the cases: each changes the tiny scene (names: its {role: object name}); returns the object to look at

def _material(obj):
    return obj.material_slots[0].material


def volume_material(sc, names):
    """A 0.9 m cube of Principled Volume (density 2) in front of the metal sphere: a material whose Volume
    output is linked."""
    m = bpy.data.materials.new("fog_volume")
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    vol = nt.nodes.new("ShaderNodeVolumePrincipled")
    vol.inputs["Density"].default_value = 2.0
    nt.links.new(vol.outputs[0], nt.nodes["Material Output"].inputs["Volume"])
    o = artist_scenes.box(sc, "fog_cube", (-0.2, -0.4, 0.45), (0.9, 0.5, 0.9), m)
    return o.name


def world_volume(sc, names):
    """Volume Scatter (density 0.3) on the world's Volume output: fog everywhere."""
    nt = sc.world.node_tree
    vs = nt.nodes.new("ShaderNodeVolumeScatter")
    vs.inputs["Density"].default_value = 0.3
    nt.links.new(vs.outputs[0], nt.nodes["World Output"].inputs["Volume"])
    return names["floor"]


def holdout_object(sc, names):
    bpy.data.objects[names["metal"]].is_holdout = True
    return names["metal"]


def holdout_collection(sc, names):
    """The glass cube in a collection of its own, set to Holdout on the view layer."""
    col = bpy.data.collections.new("holdout_coll")
    sc.collection.children.link(col)
    o = bpy.data.objects[names["glass"]]
    col.objects.link(o)
    sc.collection.objects.unlink(o)
    sc.view_layers[0].layer_collection.children["holdout_coll"].holdout = True
    return names["glass"]


def holdout_shader(sc, names):
    """The glossy plane's material: a Holdout shader on its Surface output."""
    m = _material(bpy.data.objects[names["glossy"]])
    nt = m.node_tree
    h = nt.nodes.new("ShaderNodeHoldout")
    nt.links.new(h.outputs[0], nt.nodes["Material Output"].inputs["Surface"])
    return names["glossy"]


def light_group(sc, names):
    """The point light in light group "key" of the view layer."""
    vl = sc.view_layers[0]
    vl.lightgroups.add(name="key")
    bpy.data.objects[names["light"]].lightgroup = "key"
    return names["floor"]


def pass_disabled(sc, names):
    """After Set up SSGI: the artist turns Diffuse Color off (the model needs it)."""
    sc.view_layers[0].use_pass_diffuse_color = False
    return names["floor"]


def image_unlinked(sc, names):
    """After Set up SSGI: the link Render Layers > Image -> SSGI removed."""
    from ssgi.ssgi_addon.blender import node as ssgi_node
    tree = sc.compositing_node_group
    for n in ssgi_node.ssgi_nodes(tree):
        for link in list(n.inputs[0].links):
            tree.links.remove(link)
    return names["floor"]


def image_unlinked_transparent(sc, names):
    """image_unlinked under Film > Transparent."""
    sc.render.film_transparent = True
    return image_unlinked(sc, names)


def film_transparent(sc, names):
    """Film > Transparent with a bright blue world (0.4, 0.5, 0.8) that lights the scene."""
    sc.render.film_transparent = True
    artist_scenes.world_colour(sc, (0.4, 0.5, 0.8))
    return names["floor"]


def motion_blur(sc, names):
    """Motion blur on, the metal sphere moving 0.6 m along x per frame around frame 1."""
    sc.render.use_motion_blur = True
    o = bpy.data.objects[names["metal"]]
    for f, dx in ((0, -0.6), (2, 0.6)):
        o.location.x = -0.2 + dx
        o.keyframe_insert("location", frame=f)
    sc.frame_set(1)
    return names["metal"]


def engine_cycles(sc, names):
    sc.render.engine = "CYCLES"
    return names["floor"]


def engine_workbench(sc, names):
    sc.render.engine = "BLENDER_WORKBENCH"
    return names["floor"]


def light_no_shadow(sc, names):
    bpy.data.objects[names["light"]].data.use_shadow = False
    return names["floor"]


def light_negative(sc, names):
    bpy.data.objects[names["light"]].data.energy = -300.0
    return names["floor"]


def light_zero(sc, names):
    bpy.data.objects[names["light"]].data.energy = 0.0
    return names["floor"]


def emission_negative(sc, names):
    p = _material(bpy.data.objects[names["emissive"]]).node_tree.nodes["Principled BSDF"]
    p.inputs["Emission Strength"].default_value = -8.0
    return names["emissive"]


def baseline(sc, names):
    return names["floor"]


CASES = {f.__name__: f for f in (baseline, volume_material, world_volume, holdout_object, holdout_collection,
                                 holdout_shader, light_group, pass_disabled, image_unlinked, image_unlinked_transparent,
                                 film_transparent,
                                 motion_blur, engine_cycles, engine_workbench, light_no_shadow, light_negative,
                                 light_zero, emission_negative)}
AFTER_SETUP = ("pass_disabled", "image_unlinked", "image_unlinked_transparent")  # cases that change what Set up SSGI made


def build_case(case: str, model: str, size=(64, 36), samples: int = 4):
    """Blender reset, the tiny scene built at ``size``, set up with ``model``, changed by ``case``.
    Returns (scene, names, the name of the object the case is about)."""
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    names = artist_scenes.tiny_material_scene(sc)
    artist_scenes.render_settings(sc, size)
    sc.eevee.taa_render_samples = samples
    if case not in AFTER_SETUP:
        obj = CASES[case](sc, names)
    setup_scene(sc, model)
    if case in AFTER_SETUP:
        obj = CASES[case](sc, names)
    sc.view_layers[0].update()
    return sc, names, obj


def object_box(sc, name) -> tuple[slice, slice]:
    """The object's bounding box in the image (rows from the top, columns)."""
    from bpy_extras.object_utils import world_to_camera_view
    r = sc.render
    w, h = r.resolution_x * r.resolution_percentage // 100, r.resolution_y * r.resolution_percentage // 100
    o = bpy.data.objects[name]
    pts = [world_to_camera_view(sc, sc.camera, o.matrix_world @ Vector(c)) for c in o.bound_box]
    ys = [(1 - v.y) * h for v in pts]
    xs = [v.x * w for v in pts]
    y0, y1 = max(0, int(math.floor(min(ys)))), min(h, int(math.ceil(max(ys))))
    x0, x1 = max(0, int(math.floor(min(xs)))), min(w, int(math.ceil(max(xs))))
    return slice(y0, max(y1, y0 + 1)), slice(x0, max(x1, x0 + 1))


def read_exr(path) -> np.ndarray:
    """HxWx4 float32 of a single-layer RGBA EXR, top row first."""
    import OpenEXR
    with OpenEXR.File(str(path), separate_channels=True) as f:
        ch = f.parts[0].channels
        return np.stack([np.asarray(ch[c].pixels, np.float32) for c in "RGBA"], axis=-1)


def _m(a) -> float:
    return round(float(np.mean(a)), 4)


def measure(case: str, out_dir: Path, model: str, size=(64, 36), samples: int = 4, checks: bool = False) -> dict:
    from ssgi.model import images
    from ssgi.model.errors import UserError
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    sc, names, obj = build_case(case, model, size, samples)
    ims = sc.render.image_settings
    ims.media_type, ims.file_format, ims.color_mode, ims.color_depth = "IMAGE", "OPEN_EXR", "RGBA", "32"
    frame = out_dir / f"{case}.exr"
    res: dict = {"case": case, "object": obj}
    try:
        s = RenderSession(sc, model=model, out=str(frame), keep_groups=True, checks=checks)
        summary = s.run()
    except UserError as e:
        res["status"] = str(e)
        return res
    res["status"] = "ok"
    res["warnings"] = summary.get("warnings", [])
    g = s.results[0]["groups"]
    out = read_exr(frame)
    beauty = g["beauty"]
    direct_only = np.maximum(g["albedo"] * g["direct"] + g["rest"], 0.0)
    ys, xs = object_box(sc, obj)
    hole = beauty[..., 3] < 0.5  # pixels EEVEE's own render leaves transparent (holdouts, transparent film)
    zero = beauty[..., 3] <= 0.0  # and those it leaves fully transparent
    res.update({
        "frame_rgb": _m(out[..., :3]), "frame_alpha": _m(out[..., 3]),
        "beauty_rgb": _m(beauty[..., :3]), "beauty_alpha": _m(beauty[..., 3]),
        "direct_only_rgb": _m(direct_only),
        "obj_frame_rgb": _m(out[ys, xs, :3]), "obj_frame_alpha": _m(out[ys, xs, 3]),
        "obj_beauty_rgb": _m(beauty[ys, xs, :3]), "obj_beauty_alpha": _m(beauty[ys, xs, 3]),
        "obj_direct_only_rgb": _m(direct_only[ys, xs]), "obj_albedo": _m(g["albedo"][ys, xs]),
        "obj_direct": _m(g["direct"][ys, xs]), "obj_emission": _m(g["emission"][ys, xs]),
        "holes_px": int(hole.sum()), "holes_frame_rgb": _m(out[hole, :3]) if hole.any() else None,
        "holes_albedo": _m(g["albedo"][hole]) if hole.any() else None,
        "holes_pred_rgb": _m(s.results[0]["prediction"][hole]) if hole.any() else None,
        "alpha0_px": int(zero.sum()), "alpha0_frame_rgb_max": round(float(out[zero, :3].max()), 4) if zero.any() else None,
        "alpha0_albedo_max": round(float(g["albedo"][zero].max()), 4) if zero.any() else None,
        "alpha0_depth_min": round(float(g["depth"][zero].min()), 3) if zero.any() else None,
        "rest_min": round(float(g["rest"].min()), 4),
        "rest_neg_frac": round(float((g["rest"].min(axis=-1) < -0.02).mean()), 4),
    })
    strip = np.concatenate([beauty[..., :3], out[..., :3] * out[..., 3:4], direct_only], axis=1)
    images.write_png(out_dir / f"{case}.png", images.srgb8(np.repeat(np.repeat(strip, 4, 0), 4, 1)))
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="folder for the frames and PNGs")
    ap.add_argument("--size", default="64x36")
    ap.add_argument("--samples", type=int, default=4, help="EEVEE samples (the scene's and the passes')")
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    ap.add_argument("--checks", action="store_true", help="keep the scene checks (refused cases then say why)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    model = make_model(out / "random_ref_diffuse.pt")
    size = tuple(int(v) for v in a.size.lower().split("x"))
    for case in a.cases:
        print(json.dumps(measure(case, out, model, size, a.samples, a.checks)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
