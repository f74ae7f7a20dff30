"""Direct light as a network input beyond the hard-shadow G-buffer.

- ``render_soft_direct(scene, samples=...)``: EEVEE's Diffuse Direct pass with the lights at their REAL size
  (soft shadows), in the same direct-only set-up as ``passes.render_gbuffer`` (world lights nothing, light
  probes hidden, no ray tracing / fast GI, light threshold 0), pixels point-sampled at their centres like the
  1-sample G-buffer (EEVEE's TAA then spends its samples on the shadows, not on anti-aliasing).
- ``render_cycles_direct(scene, samples, ...)``: Cycles' Diffuse Direct pass with real light sizes, a black
  world, point-sampled pixels and no bounces (direct light only: the same pass, cheaper); the reference for
  both of the above, and (with ``denoise``) the emitter-aware direct input.
- ``render_emitter_direct(scene, ...)``: the direct light that emissive meshes cast (EEVEE's Diffuse Direct
  ignores them): Cycles' Diffuse Direct with the lamp objects hidden, at a few samples, denoised by OIDN in the
  compositor (Denoise node with the Normal pass as guide). Added to ``render_soft_direct`` it is the direct
  light of lamps and emitters (``lamps=True`` gives Cycles' own lamps too, noisier than EEVEE's).
- ``emission_panel_room(seed, scene)``: a closed random room lit only by an emissive ceiling panel (measurements
  and tests). The measurements behind the defaults: docs/direct_light.md.

Every function returns HxWx3 float32, top row first, and restores the scene's settings it overrides.
"""
from __future__ import annotations

import contextlib

import bpy
import numpy as np

from . import passes

# Chosen by benchmarks/direct_light.py (docs/direct_light.md): the cheapest setting close to Cycles.
# 4 TAA samples, no jitter, 4 shadow rays (EEVEE's maximum) of 12 steps: +5.5 dB over the hard input against
# Cycles' soft direct on 6 rooms, 2 dB under 16 jittered samples at a third of the time; jitter banded the
# penumbrae at 4 samples and lost up to 20 % of the light in one room.
SOFT_SAMPLES = 4
SOFT_JITTER = False
SOFT_RAY_COUNT = 4
SOFT_STEP_COUNT = 12
EMITTER_SAMPLES = 4  # + OIDN: 42.2 / 34.8 dB on two panel rooms (1 spp: 37.8 / 32.7), ~0.3-0.9 s at 240x135


@contextlib.contextmanager
def _overrides(items):
    """Set each (owner, attribute, value) of ``items``; restore the old values on exit."""
    saved = []
    try:
        for owner, attr, value in items:
            saved.append((owner, attr, getattr(owner, attr)))
            setattr(owner, attr, value)
        yield
    finally:
        for owner, attr, value in reversed(saved):
            setattr(owner, attr, value)


def _lights(scene) -> list:
    return list({o.data for o in scene.objects if o.type == "LIGHT"})


def render_soft_direct(scene, samples: int = SOFT_SAMPLES, jitter: bool = SOFT_JITTER,
                       ray_count: int = SOFT_RAY_COUNT, step_count: int = SOFT_STEP_COUNT,
                       point_sampled: bool = True) -> np.ndarray:
    """EEVEE's Diffuse Direct with the lights at their real size (soft shadows): HxWx3 float32, top row first.

    ``samples``: EEVEE TAA samples (the shadows soften over them); ``jitter``: each light's
    ``use_shadow_jitter`` (shadow maps re-rendered from points on the light every sample); ``ray_count`` /
    ``step_count``: ``scene.eevee.shadow_ray_count`` / ``shadow_step_count`` (shadow-map ray tracing that fakes
    the penumbra within one sample). ``point_sampled``: pixel filter ~0, so that the pass lines up with the
    1-sample G-buffer groups."""
    passes.configure_gbuffer(scene, ("direct",), samples=samples)
    ee = scene.eevee
    items = [(ee, "shadow_ray_count", int(ray_count)), (ee, "shadow_step_count", int(step_count))]
    items += [(li, "use_shadow_jitter", bool(jitter)) for li in _lights(scene)]
    if point_sampled:
        items.append((scene.render, "filter_size", 0.0))
    with _overrides(items), passes._direct_only_world(scene):
        out = passes._render(scene)
    return passes._group(out, "direct")[..., :3]


def _configure_cycles_direct(scene, samples: int, seed: int):
    passes.configure_cycles(scene, samples, seed)
    c = scene.cycles
    # direct light only: bounces 0 (the Diffuse Direct pass is the same; measured in docs/direct_light.md)
    return [(c, "max_bounces", 0), (c, "diffuse_bounces", 0), (c, "glossy_bounces", 0),
            (c, "transmission_bounces", 0), (c, "volume_bounces", 0), (c, "transparent_max_bounces", 0)]


def render_cycles_direct(scene, samples: int, seed: int = 0, hard: bool = False,
                         point_sampled: bool = True) -> np.ndarray:
    """Cycles' Diffuse Direct pass (lamps and emissive meshes), real light sizes unless ``hard``, world black,
    no bounces: HxWx3 float32, top row first."""
    items = _configure_cycles_direct(scene, samples, seed)
    scene.view_layers[0].use_pass_diffuse_direct = True
    with contextlib.ExitStack() as ctx:
        ctx.enter_context(_overrides(items))
        ctx.enter_context(passes._direct_only_world(scene))
        if hard:
            ctx.enter_context(passes.hard_lights(scene))
        if point_sampled:
            ctx.enter_context(passes._point_sampled(scene))
        out = passes._render(scene)
    return passes._group(out, "direct")[..., :3]


def _denoise_tree(scene, name: str):
    """A compositor tree: Render Layers' Diffuse Direct -> Denoise (Normal as guide, no albedo: the pass holds
    light, not colour) -> the group output."""
    tree = bpy.data.node_groups.new(name, "CompositorNodeTree")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    rl = tree.nodes.new("CompositorNodeRLayers")
    rl.scene = scene  # its outputs follow the scene's enabled passes (enable them first)
    dn = tree.nodes.new("CompositorNodeDenoise")
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(rl.outputs["Diffuse Direct"], dn.inputs["Image"])
    tree.links.new(rl.outputs["Normal"], dn.inputs["Normal"])
    tree.links.new(dn.outputs["Image"], out.inputs[0])
    return tree


def render_emitter_direct(scene, samples: int = EMITTER_SAMPLES, seed: int = 0, denoise: bool = True,
                          point_sampled: bool = True, lamps: bool = False) -> np.ndarray:
    """Diffuse direct light from emissive meshes (and lamp objects too with ``lamps``): Cycles' Diffuse Direct
    (real light sizes, world black, no bounces) at ``samples`` spp, OIDN-denoised through the compositor's
    Denoise node when ``denoise``. Without ``lamps`` the lamp objects are hidden: the result adds to
    ``render_soft_direct`` (which has the lamps and no emitters). HxWx3 float32, top row first."""
    if not lamps:
        with passes._hidden_from_render(scene, ("LIGHT",)):
            return render_emitter_direct(scene, samples, seed, denoise, point_sampled, lamps=True)
    if not denoise:
        return render_cycles_direct(scene, samples, seed, point_sampled=point_sampled)
    passes._check_camera(scene)
    items = _configure_cycles_direct(scene, samples, seed)
    vl = scene.view_layers[0]
    items += [(vl, "use_pass_diffuse_direct", True), (vl, "use_pass_normal", True)]
    tree = None
    try:
        with contextlib.ExitStack() as ctx:
            ctx.enter_context(_overrides(items))
            tree = _denoise_tree(scene, "ssgi.denoise_direct")
            ctx.enter_context(_overrides([(scene, "compositing_node_group", tree)]))
            ctx.enter_context(passes._direct_only_world(scene))
            if point_sampled:
                ctx.enter_context(passes._point_sampled(scene))
            out = passes._render(scene, composite=True)
        return passes._rgb(out, passes.COMPOSITE_LAYER)
    finally:
        if tree is not None:
            bpy.data.node_groups.remove(tree)


def _lit_input(sock) -> bool:
    """Whether a shader socket may give off light: linked (could be anything), or a default above 0 (a colour's or
    a vector's first three components; a socket without a value, such as a shader's: 0)."""
    if sock is None:
        return False
    if sock.is_linked:
        return True
    v = getattr(sock, "default_value", 0.0)
    try:
        return max(float(c) for c in list(v)[:3]) > 0.0
    except TypeError:
        return float(v) > 0.0


# the (strength, colour) inputs of the shader nodes that give off light
EMISSION_INPUTS = {"ShaderNodeEmission": ("Strength", "Color"),
                   "ShaderNodeBsdfPrincipled": ("Emission Strength", "Emission Color")}


def _emission_sockets(node):
    """(strength, colour) sockets of ``node`` when it is an emitting node whose inputs may give off light
    (``_lit_input``); None otherwise."""
    names = EMISSION_INPUTS.get(node.bl_idname)
    if names is None:
        return None
    st, col = node.inputs.get(names[0]), node.inputs.get(names[1])
    return (st, col) if _lit_input(st) and _lit_input(col) else None


def has_emitters(scene) -> bool:
    """True when a rendered mesh's material may emit light (an Emission shader, or a Principled BSDF with an
    Emission Strength and Colour above 0, or either linked to other nodes). False means the emitter render
    would be black, so ``render_emitter_direct`` is not needed (``emitter_direct`` returns zeros then)."""
    mats = {s.material for o in scene.objects if o.type in ("MESH", "CURVE", "SURFACE", "META", "FONT")
            and not o.hide_render for s in o.material_slots if s.material is not None}
    for m in mats:
        nt = m.node_tree
        if nt is None:
            continue
        for n in nt.nodes:
            if _emission_sockets(n) is not None:
                return True
            if n.bl_idname == "ShaderNodeGroup":  # a group may hide an emitter: render it
                return True
    return False


def _tree_may_emit(tree, seen: set) -> bool:
    """Whether a shader node tree holds a node that may add to EEVEE's Emission pass: an Emission shader or a
    Principled BSDF whose emission may be above 0 (``_emission_sockets``), a Background shader, any other node with
    an emission or blackbody input that may be above 0 (the Specular BSDF's Emissive Color, a volume's emission), or a
    group whose tree does (``seen``: trees already looked at)."""
    if tree is None or tree.as_pointer() in seen:  # (not by name: every material's own tree is "Shader Nodetree")
        return False
    seen.add(tree.as_pointer())
    for n in tree.nodes:
        if n.bl_idname in EMISSION_INPUTS:
            if _emission_sockets(n) is not None:
                return True
            continue
        if n.bl_idname == "ShaderNodeBackground":
            return True
        if n.bl_idname == "ShaderNodeGroup":
            if _tree_may_emit(n.node_tree, seen):
                return True
            continue
        if any(("emissi" in s.name.lower() or "blackbody" in s.name.lower()) and _lit_input(s) for s in n.inputs):
            return True
    return False


def materials_may_emit() -> bool:
    """False only when no material of the file that anything uses can write EEVEE's Emission pass
    (``_tree_may_emit``): then that pass is black to the bit in any render (lights and the world write other
    passes), so the render path need not write it (``passes.render_rest``). Every used material of the file
    is looked at, not only the scene's objects', so that materials that reach the render by collection instances,
    geometry nodes or linked libraries count too."""
    seen: set = set()
    return any(m.users and _tree_may_emit(m.node_tree, seen) for m in bpy.data.materials)


def _constant_emission(mat):
    """(strength, (r, g, b)) of a material whose light comes from one Principled BSDF or Emission node with
    constant (unlinked) emission inputs; None for anything else (textured or linked emission, groups, several
    emitting nodes)."""
    nt = mat.node_tree if mat is not None else None
    if nt is None:
        return None
    found = []
    for n in nt.nodes:
        if n.bl_idname == "ShaderNodeGroup":
            return None
        socks = _emission_sockets(n)
        if socks is None:
            continue
        st, col = socks
        if st.is_linked or col.is_linked:
            return None
        found.append((float(st.default_value), tuple(float(c) for c in col.default_value[:3])))
    return found[0] if len(found) == 1 else None


# A planar emitter is a mesh whose bounding box is this thin against its size (a panel, a screen, a window card)
PLANAR_RATIO = 1e-3


def planar_emitters(scene) -> list[tuple]:
    """[(object, strength, colour)] of the rendered mesh objects that are flat across their local Z (bounding box
    thinner there than ``PLANAR_RATIO`` of its larger side, as a default plane; a mesh flat along local X or Y is
    not counted), have one material slot, and emit a constant light (``_constant_emission``): the emitters
    ``emitter_proxies`` stands a lamp in for."""
    out = []
    for o in scene.objects:
        if o.type != "MESH" or o.hide_render or len(o.material_slots) != 1:
            continue
        d = o.dimensions
        side = max(d.x, d.y)
        if side <= 0 or d.z > PLANAR_RATIO * side or d.z > min(d.x, d.y):
            continue
        e = _constant_emission(o.material_slots[0].material)
        if e is not None:
            out.append((o, *e))
    return out


# A mesh emitter longer than this many times its thickness is a tube or strip (a neon tube, a light bar): its proxy is
# a row of sphere lights along its length (``solid_emitters``); shorter ones (an orb, a lamp shade) get one
TUBE_RATIO = 4.0
TUBE_LIGHTS_MAX = 8  # sphere lights along a tube at most


def _world_area(o, dg) -> tuple[float, bool]:
    """(surface area in m^2 of ``o``'s evaluated mesh in world space, whether the mesh is closed: every edge shared
    by two faces)."""
    ev = o.evaluated_get(dg)
    me = ev.to_mesh()
    try:
        me.calc_loop_triangles()
        n = len(me.vertices)
        co = np.empty(n * 3, np.float32)
        me.vertices.foreach_get("co", co)
        co = co.reshape(n, 3).astype(np.float64)
        m = np.array(ev.matrix_world, np.float64)
        co = co @ m[:3, :3].T + m[:3, 3]
        t = np.empty(len(me.loop_triangles) * 3, np.int32)
        me.loop_triangles.foreach_get("vertices", t)
        t = t.reshape(-1, 3)
        area = 0.5 * float(np.linalg.norm(np.cross(co[t[:, 1]] - co[t[:, 0]], co[t[:, 2]] - co[t[:, 0]]), axis=1).sum())
        edge = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("edge_index", edge)
        faces_per_edge = np.bincount(edge, minlength=len(me.edges))  # each face uses each of its edges once
        closed = bool(len(me.edges)) and bool((faces_per_edge == 2).all())
        return area, closed
    finally:
        ev.to_mesh_clear()


def solid_emitters(scene) -> list[tuple]:
    """[(object, strength, colour)] of the rendered mesh objects with one material slot that emit a constant light
    (``_constant_emission``) and are not planar (``planar_emitters``): orbs, lamp shades, neon tubes, boxes."""
    flat = {o.name for o, _s, _c in planar_emitters(scene)}
    out = []
    for o in scene.objects:
        if o.type != "MESH" or o.hide_render or len(o.material_slots) != 1 or o.name in flat:
            continue
        if max(o.dimensions) <= 0:
            continue
        e = _constant_emission(o.material_slots[0].material)
        if e is not None and e[0] > 0 and max(e[1]) > 0:
            out.append((o, *e))
    return out


def solid_proxy_lights(o, strength: float, dg) -> list[tuple]:
    """[(world position, radius, power W)] of the sphere lights standing in for the non-planar emitter ``o``:
    power ``pi x strength x area`` in all (a Lambertian surface of that radiance; an open mesh, such as a lamp shade,
    gives off light from both sides of its faces: twice that), one sphere light at the centre of a compact emitter
    (radius: half its mean size), or a row of up to ``TUBE_LIGHTS_MAX`` along the long axis of a tube (radius: half
    their spacing, so that the row lights a nearby wall smoothly). A point light of power P and radius r is a
    sphere of radiance P / (4 pi^2 r^2): the same power as the emitter's surface."""
    import math

    from mathutils import Vector
    area, closed = _world_area(o, dg)
    power = math.pi * strength * area * (1.0 if closed else 2.0)
    d = o.dimensions
    m = o.matrix_world
    centre = m @ (0.125 * sum((Vector(c) for c in o.bound_box), Vector()))
    k = max(range(3), key=lambda i: d[i])
    long, thick = d[k], max(d[i] for i in range(3) if i != k)
    if long <= TUBE_RATIO * max(thick, 1e-6):
        return [(centre, 0.5 * sum(d) / 3.0, power)]
    n = min(TUBE_LIGHTS_MAX, max(2, math.ceil(long / (2.0 * max(thick, 1e-6)))))
    axis = (m.to_3x3() @ Vector([1.0 if i == k else 0.0 for i in range(3)])).normalized() * long
    step = 1.0 / n
    return [(centre + axis * ((i + 0.5) * step - 0.5), 0.5 * long * step, power / n) for i in range(n)]


# A side of a planar emitter that faces a surface closer than this fraction of the emitter's larger side, at its
# centre and near each corner, gets no proxy (``open_sides``): a panel hung just under a ceiling gives off its back
# light into the gap, where no camera sees it (the artist test set's Cornell panel hangs 2 mm under the ceiling, 0.4 % of its
# 0.5 m side). Such a proxy still costs EEVEE's render its light evaluation at every pixel, and, unshadowed (the
# GI-off one render's), leaks light through the ceiling onto whatever lies above it.
BLOCKED_GAP = 0.02
_PROBES = ((0.0, 0.0), (-0.45, -0.45), (0.45, -0.45), (-0.45, 0.45), (0.45, 0.45))  # in the emitter's size


def open_sides(scene, o) -> list[bool]:
    """[front (+Z), back (-Z)]: whether each side of the planar emitter ``o`` faces open space, False where rays from
    its centre and near its four corners (``_PROBES``) all hit a surface other than the emitter itself
    (``_hits_other``) within ``BLOCKED_GAP`` of its larger side
    (``Scene.ray_cast`` on the evaluated depsgraph, so the surfaces at the scene's current frame)."""
    from mathutils import Vector

    from .surround import _depsgraph
    dg = _depsgraph(scene)
    m = o.matrix_world
    d = o.dimensions
    gap = BLOCKED_GAP * max(d.x, d.y)
    n = (m.to_3x3() @ Vector((0.0, 0.0, 1.0))).normalized()
    # the probes on the plane through the emitter's origin, in world space (o.dimensions are world-scaled)
    ax = (m.to_3x3() @ Vector((1.0, 0.0, 0.0))).normalized() * d.x
    ay = (m.to_3x3() @ Vector((0.0, 1.0, 0.0))).normalized() * d.y
    c = m.translation
    out = []
    for sign in (1.0, -1.0):
        ray = n * sign
        blocked = True
        for u, v in _PROBES:
            if not _hits_other(scene, dg, o, c + ax * u + ay * v, ray, gap):
                blocked = False
                break
        out.append(not blocked)
    return out


def _hits_other(scene, dg, o, origin, ray, distance: float) -> bool:
    """Whether a ray from ``origin`` hits a surface other than the emitter ``o`` itself within ``distance`` (an
    emitter with some thickness, or whose origin is off its faces, is stepped through)."""
    eps = 1e-6 + 1e-4 * distance
    left = distance
    for _ in range(8):
        hit, loc, _n, _i, obj, _m = scene.ray_cast(dg, origin, ray, distance=left)
        if not hit:
            return False
        if getattr(obj, "original", obj) != o:
            return True
        step = (loc - origin).length + eps
        origin, left = loc + ray * eps, left - step
        if left <= 0:
            return False
    return True


def _proxy_light(scene, emitter, kind: str, energy: float, colour, shadows: bool, made: list):
    """A light of ``kind`` standing in for ``emitter``, linked to ``scene``'s collection and appended to ``made``."""
    li = bpy.data.lights.new(f"ssgi_proxy_{emitter.name}", kind)
    li.energy = float(energy)
    li.color = colour
    li.use_shadow = bool(shadows)
    ob = bpy.data.objects.new(li.name, li)
    scene.collection.objects.link(ob)
    made.append(ob)
    return ob


def make_proxies(scene, shadows: bool = True, sides: str = "both", made: list | None = None,
                 shapes: str = "planar") -> list:
    """The lights ``emitter_proxies`` stands in for the emitters (area lights for the planar ones; with ``shapes``
    "all" sphere lights for the others too), linked to ``scene``'s collection and left there (a compiled set-up
    keeps them in its file); each is appended to ``made`` as it is made."""
    import math

    from mathutils import Matrix
    made = [] if made is None else made
    flip = Matrix.Rotation(math.pi, 3, "X")
    for o, strength, colour in planar_emitters(scene):
        d = o.dimensions
        rot = o.matrix_world.to_3x3().normalized()
        front, back = open_sides(scene, o) if sides == "open" else (True, True)
        # an area light shines along its -Z: first the plane's front (+Z); no proxy for a side facing a surface
        for side in [s for s, is_open in ((rot @ flip, front), (rot, back)) if is_open]:
            ob = _proxy_light(scene, o, "AREA", math.pi * strength * d.x * d.y, colour, shadows, made)
            ob.data.shape, ob.data.size, ob.data.size_y = "RECTANGLE", float(d.x), float(d.y)
            ob.matrix_world = Matrix.Translation(o.matrix_world.translation) @ side.to_4x4()
    if shapes == "all":
        from .surround import _depsgraph
        dg = _depsgraph(scene)
        for o, strength, colour in solid_emitters(scene):
            for pos, radius, power in solid_proxy_lights(o, strength, dg):
                ob = _proxy_light(scene, o, "POINT", power, colour, shadows, made)
                ob.data.shadow_soft_size = float(radius)
                ob.location = pos
    elif shapes != "planar":
        raise ValueError(f"proxy shapes {shapes!r}: 'planar' or 'all'")
    return made


@contextlib.contextmanager
def emitter_proxies(scene, shadows: bool = True, sides: str = "both", shapes: str = "planar"):
    """Stand an area light in for each planar emitter (``planar_emitters``) while the block runs, and remove them
    after; with ``shadows`` False the proxies cast no shadow (the one render's, passes.ONE_RENDER_SETTINGS:
    their shadows cost the Cornell shot's 960x540 frame 0.88 s of 10.87 on Mesa, docs/one_render.md). EEVEE lights nothing from an emissive mesh off screen (its ray tracing sees only the screen), so in
    its own render the walls an emissive panel lights stay dark and a mirror reflects them dark, where Cycles
    shows them lit: the rest (EEVEE's reflections, transmission) then misses that light. Each proxy is a
    rectangle of the emitter's size and place, one facing each side (an emissive plane gives off light on both
    sides; with ``sides`` "open" only for a side that faces open space, ``open_sides``: none for a side pressed
    against a surface), of the emitter's colour and power ``pi x strength x area`` (the power of a Lambertian surface of
    that radiance); its specular factor 1, so that glossy surfaces and mirrors show the panel's highlight as
    Cycles does. Measured on the artist test set's Cornell box with its emissive panel (docs/fit.md): the
    ceiling of a diffuse-part model (Cycles' diffuse part + EEVEE's rest) rose from 29.4 to 34.5 dB on
    withheld frames. With ``shapes`` "all", the other emitters of constant light (``solid_emitters``: orbs, lamp
    shades, neon tubes) get sphere lights too (``solid_proxy_lights``); "planar": only the planar ones. Yields the
    proxy objects."""
    made = []
    try:
        make_proxies(scene, shadows, sides, made, shapes)
        yield made
    finally:
        for ob in made:
            li = ob.data
            bpy.data.objects.remove(ob)
            bpy.data.lights.remove(li)


def emitter_direct(scene) -> np.ndarray:
    """The ``emit_direct`` group: ``render_emitter_direct`` at its defaults, or zeros (no render) when the scene
    has no emitter (``has_emitters``)."""
    if has_emitters(scene):
        return render_emitter_direct(scene)
    r = scene.render
    h = int(r.resolution_y * r.resolution_percentage / 100)
    w = int(r.resolution_x * r.resolution_percentage / 100)
    return np.zeros((h, w, 3), np.float32)


PANEL_STRENGTH = 40.0  # emission_panel_room's panel: Cycles' Diffuse Direct mean 0.19 / 0.13 in rooms 2 / 3 (240x135)


def emission_panel_room(seed: int, scene, size=(1.2, 0.8), strength: float = PANEL_STRENGTH, camera_tilt: float = 0.0,
                        keep_lamps: bool = False):
    """Random closed room ``seed`` (room.build_room; ValueError for a seed with an open side) lit ONLY by an emissive ceiling
    panel: its lamps are removed and a ``size`` (m) plane with an Emission shader of ``strength`` hangs 1 cm
    under the ceiling, facing down; ``camera_tilt`` (radians) pitches the camera up (0.4 puts room 2's panel
    on screen); ``keep_lamps`` keeps the room's lamps too (a mixed-light room). The measurement and test scene of emitter light (everything carries ``ssgi_room``, so
    room.clear_room removes it)."""
    import math

    from . import room

    if room.room_params(seed)["open_side"]:
        raise ValueError(f"room {seed} has an open side; emission_panel_room needs a closed room")
    room.build_room(seed, scene)
    lamps = [o for o in scene.objects if o.type == "LIGHT" and not keep_lamps]
    data = [o.data for o in lamps]
    bpy.data.batch_remove(lamps)
    bpy.data.batch_remove([d for d in data if d.users == 0])
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    W, D, H = room.room_params(seed)["size"]
    m = bpy.data.materials.new(f"{room.PREFIX}emission_panel")
    m["ssgi_room"] = True
    nt = m.node_tree
    nt.nodes.clear()
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (1.0, 0.95, 0.85, 1.0)
    em.inputs["Strength"].default_value = float(strength)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(em.outputs["Emission"], out.inputs["Surface"])
    me = room._mesh("plane", f"{room.PREFIX}emission_panel")
    me.materials.append(m)
    o = room._link(scene, bpy.data.objects.new(f"{room.PREFIX}emission_panel", me))
    o.location, o.rotation_euler, o.scale = (0.0, 0.0, H - 0.01), (math.pi, 0.0, 0.0), (size[0] / 2, size[1] / 2, 1.0)
    scene.camera.rotation_euler.x += camera_tilt
    return scene
