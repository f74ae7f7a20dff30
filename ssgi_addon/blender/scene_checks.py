"""What the SSGI render path cannot handle in an artist's scene ("Bad input"), found before it renders.

    findings = check_scene(scene, spec, target)   # [Finding(code, message, fatal)]

RenderSession (pipeline/render.py) calls it in its constructor: a fatal finding raises UserError before anything
changes; the others are warnings, printed once per render on stderr ("SSGI: warning: ..."), shown in the SSGI
node's label and listed in the render's summary ("warnings") and the operator's report.

Each decision comes from a measurement through the real render path (benchmarks/bad_input.py, the tiny
emissive/metal/glass/glossy scene with a random diffuse-part model, real EEVEE); docs/node.md "What SSGI refuses
or warns about" has the numbers. Refused: what makes the whole image wrong (a world volume, negative emission,
an unlinked SSGI Image input under transparent film, a volume with a whole-image model). Warned: what leaves the
image right, or right except a named part.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...model import channels as ch
from . import node as ssgi_node


@dataclass(frozen=True)
class Finding:
    code: str  # short id, e.g. "volume_material" (tests and the node label use it)
    message: str  # one line: what, where (object/material/setting), what it does to the image, what to do
    fatal: bool = False


ENGINE_NAMES = {"CYCLES": "Cycles", "BLENDER_WORKBENCH": "Workbench", "BLENDER_EEVEE": "EEVEE"}


def _visible_objects(scene):
    """The objects the first view layer renders (not hidden from the render, in an enabled collection)."""
    vl = scene.view_layers[0]
    return [o for o in vl.objects if not o.hide_render]


def _materials(obj):
    return [s.material for s in getattr(obj, "material_slots", ()) if s.material is not None]


def _active_output(tree, idname):
    outs = [n for n in tree.nodes if n.bl_idname == idname]
    return next((n for n in outs if n.is_active_output), outs[0] if outs else None)


def _linked(tree, idname, socket) -> bool:
    if tree is None:
        return False
    out = _active_output(tree, idname)
    return out is not None and socket in out.inputs and bool(out.inputs[socket].links)


def _names(items, n=3) -> str:
    items = sorted(items)
    return ", ".join(repr(i) for i in items[:n]) + (f" and {len(items) - n} more" if len(items) > n else "")


def _holdout_collections(layer_collection, out):
    for c in layer_collection.children:
        if c.holdout and not c.exclude:
            out.append(c.name)
        _holdout_collections(c, out)
    return out


def _negative_emission(mat) -> float | None:
    """The most negative unlinked emission strength of ``mat``'s nodes (Principled "Emission Strength",
    Emission "Strength"), or None."""
    worst = None
    for n in mat.node_tree.nodes if mat.node_tree is not None else ():
        key = "Emission Strength" if n.bl_idname == "ShaderNodeBsdfPrincipled" else \
            "Strength" if n.bl_idname == "ShaderNodeEmission" else None
        if key is None or key not in n.inputs or n.inputs[key].links:
            continue
        v = float(n.inputs[key].default_value)
        if v < 0 and (worst is None or v < worst):
            worst = v
    return worst


def _check_materials(scene, objs, target, found):
    vol_mats, holdout_mats, neg = {}, {}, {}
    for o in objs:
        for m in _materials(o):
            nt = m.node_tree
            if _linked(nt, "ShaderNodeOutputMaterial", "Volume"):
                vol_mats.setdefault(m.name, []).append(o.name)
            if nt is not None and any(n.bl_idname == "ShaderNodeHoldout" for n in nt.nodes) and \
                    _linked(nt, "ShaderNodeOutputMaterial", "Surface"):
                out = _active_output(nt, "ShaderNodeOutputMaterial")
                if out.inputs["Surface"].links[0].from_node.bl_idname == "ShaderNodeHoldout":
                    holdout_mats.setdefault(m.name, []).append(o.name)
            v = _negative_emission(m)
            if v is not None:
                neg[m.name] = v
    if vol_mats:
        where = "; ".join(f"material {m!r} on {_names(obs)}" for m, obs in sorted(vol_mats.items()))
        if ch.adds_part(target):
            found.append(Finding("volume_material", f"volume shader ({where}): EEVEE renders the volume itself, but "
                                 f"the diffuse light SSGI predicts inside and behind it is not dimmed by it and its "
                                 f"volume shadows differ; expect errors there (unlink the Volume output to avoid)"))
        else:
            found.append(Finding("volume_material", f"volume shader ({where}): this model predicts the whole image "
                                 f"and renders no volumes; use a diffuse-part model (target ref_diffuse) or unlink "
                                 f"the material's Volume output", fatal=True))
    for m, v in sorted(neg.items()):
        found.append(Finding("emission_negative", f"material {m!r} has a negative emission strength ({v:g}): SSGI's "
                             f"network takes only light >= 0 and the image there would be clamped to black; set its "
                             f"Emission Strength to 0 or more", fatal=True))
    if holdout_mats:
        where = "; ".join(f"material {m!r} on {_names(obs)}" for m, obs in sorted(holdout_mats.items()))
        found.append(_holdout("holdout_shader", f"Holdout shader ({where})"))


def _holdout(code, what) -> Finding:
    return Finding(code, f"{what}: its pixels come out transparent as in EEVEE, but SSGI's network sees it as a black "
                   f"surface (Diffuse Color 0 there), so the light it bounces onto its surroundings is missing from "
                   f"the prediction; turn Holdout off if that light matters")


def check_scene(scene, spec, target: str = ch.DIFFUSE_TARGET) -> list[Finding]:
    """What in ``scene`` the SSGI path with a model of channel ``spec`` and ``target`` cannot handle, fatal
    first. Reads the scene only."""
    target = ch.check_target(target)
    found: list[Finding] = []
    r = scene.render
    objs = _visible_objects(scene)
    vl = scene.view_layers[0]

    # the world
    w = scene.world
    if w is not None and getattr(w, "use_nodes", True) and _linked(w.node_tree, "ShaderNodeOutputWorld", "Volume"):
        found.append(Finding("world_volume", f"world {w.name!r} has a Volume shader linked (fog over the whole "
                             f"image): SSGI's passes are not dimmed by it and the image gets dark streaks; unlink the "
                             f"world's Volume output (or give the fog to a mesh's material)", fatal=True))

    _check_materials(scene, objs, target, found)

    # the SSGI node's Image input gives the alpha
    unlinked = [n.name for n in ssgi_node.ssgi_nodes(scene.compositing_node_group) if not n.inputs[0].links]
    if unlinked:
        if r.film_transparent:
            found.append(Finding("image_unlinked", f"SSGI node {unlinked[0]!r} has nothing linked to its Image input "
                                 f"and Film > Transparent is on: the frame would be opaque; link Render Layers > Image "
                                 f"to it (or run Set up SSGI)", fatal=True))
        else:
            found.append(Finding("image_unlinked", f"SSGI node {unlinked[0]!r} has nothing linked to its Image input: "
                                 f"it takes the alpha from there (now 1 everywhere); link Render Layers > Image to it"))

    # holdouts
    held = sorted(o.name for o in objs if o.is_holdout)
    if held:
        found.append(_holdout("holdout_object", f"object(s) {_names(held)} set to Holdout"))
    cols = _holdout_collections(vl.layer_collection, [])
    if cols:
        found.append(_holdout("holdout_collection", f"collection(s) {_names(cols)} set to Holdout in view layer "
                              f"{vl.name!r}"))

    # the engine
    if r.engine != "BLENDER_EEVEE":
        found.append(Finding("engine", f"scene {scene.name!r} renders with {ENGINE_NAMES.get(r.engine, r.engine)}: "
                             f"SSGI renders EEVEE's passes and EEVEE's own image whatever the engine, so this engine's "
                             f"settings are not used; set Render Engine to EEVEE to see what SSGI builds on"))

    if r.use_motion_blur:
        found.append(Finding("motion_blur", f"motion blur is on in scene {scene.name!r}: EEVEE's Diffuse passes are "
                             f"not blurred like its image, so moving objects get a ghost edge; turn Motion Blur off "
                             f"for SSGI renders"))

    # light groups (EEVEE renders no light-group passes)
    grouped = sorted(o.name for o in objs if o.type == "LIGHT" and getattr(o, "lightgroup", ""))
    if len(vl.lightgroups) and grouped:
        found.append(Finding("light_group", f"light(s) {_names(grouped)} in light groups of view layer {vl.name!r}: "
                             f"EEVEE renders no light-group passes, so SSGI's image holds every light and compositor "
                             f"links from light-group passes get nothing"))

    # lights
    lights = [o for o in objs if o.type == "LIGHT"]
    neg = sorted(o.name for o in lights if o.data.energy < 0)
    zero = sorted(o.name for o in lights if o.data.energy == 0)
    lit_inputs = {"direct", "direct_soft"} & set(ch.required_groups(tuple(spec)))
    noshadow = sorted(o.name for o in lights if not o.data.use_shadow and o.data.energy > 0) if lit_inputs else []
    if neg:
        found.append(Finding("light_negative", f"light(s) {_names(neg)} have negative power: EEVEE, and so SSGI, "
                             f"render them as off (Cycles would subtract light); set the power to 0 or more"))
    if zero:
        found.append(Finding("light_zero", f"light(s) {_names(zero)} have zero power and light nothing"))
    if noshadow:
        found.append(Finding("light_no_shadow", f"light(s) {_names(noshadow)} cast no shadows (Shadow off): SSGI's "
                             f"input shows their light unshadowed, as EEVEE does, but the network learned only "
                             f"shadowed lights, so its bounce light from them is less sure"))
    found.sort(key=lambda f: not f.fatal)
    return found


def node_label(findings) -> str:
    """The SSGI node's label for a render with these (non-fatal) findings: "SSGI" or "SSGI: 2 warnings (...)"."""
    warn = [f.code for f in findings if not f.fatal]
    if not warn:
        return ssgi_node.NODE_LABEL
    return f"{ssgi_node.NODE_LABEL}: {len(warn)} warning{'s' if len(warn) > 1 else ''} ({', '.join(warn)})"[:63]
