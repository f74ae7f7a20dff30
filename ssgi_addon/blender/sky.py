"""The ``sky`` input group (model/channels.py, model/sky.py): the world's unoccluded light on each surface, from the
world's L1 spherical harmonics and the normal pass, without a render of the scene.

The world is rendered into a small equirectangular image by Cycles, in a scene of its own that holds only a
panoramic camera (the artist's scene is not touched): ENV_SIZE at ENV_SAMPLES samples, 0.5-1.3 s on 2 cores
(a Sky Texture world the most). A world that lights nothing (``passes.world_is_black``) costs no render.
The coefficients are kept for the world as it is (``fingerprint``: its node tree's nodes, their settings, socket
values and links, at the current frame), so the frames of an animation pay that render once, as EEVEE pays its shader
compilation once; any change to the world makes a new one.
"""
from __future__ import annotations

import bpy
import numpy as np

from ...model import sky as sky_model

ENV_SIZE = (64, 32)
ENV_SAMPLES = 16


def world_env(world, size: tuple[int, int] = ENV_SIZE, samples: int = ENV_SAMPLES) -> np.ndarray:
    """HxWx3 float32: ``world``'s radiance seen by an equirectangular camera with rotation 0 (model/sky.py's layout),
    rendered by Cycles in a scene of its own, removed afterwards."""
    from . import passes

    w, h = size
    sc = bpy.data.scenes.new("ssgi_sky_probe")
    cam_data = bpy.data.cameras.new("ssgi_sky_probe")
    cam = bpy.data.objects.new("ssgi_sky_probe", cam_data)
    try:
        sc.world = world
        cam_data.type = "PANO"
        cam_data.panorama_type = "EQUIRECTANGULAR"
        sc.collection.objects.link(cam)
        sc.camera = cam
        passes.configure_cycles(sc, samples, seed=0, denoise=False)
        r = sc.render
        r.resolution_x, r.resolution_y, r.resolution_percentage = w, h, 100
        p = passes._render(sc)["Combined"]
        return np.stack([p[c] for c in "RGB"], axis=-1).astype(np.float32)
    finally:
        bpy.data.scenes.remove(sc)
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)


_SKIP = {"rna_type", "location", "location_absolute", "width", "height", "dimensions", "select", "show_options",
         "show_preview", "show_texture", "hide", "mute_ui", "label", "color", "use_custom_color", "parent",
         "warning_propagation"}
_cache: dict[str, np.ndarray] = {}
CACHE_SIZE = 8
renders = 0  # world_env renders made by world_coefficients (tests read it)


def _value(v):
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    if isinstance(v, (set, frozenset)):  # enum flags
        return tuple(sorted(map(str, v)))
    try:
        return tuple(_value(x) for x in v)
    except TypeError:
        return repr(v)


def _tree(nt, seen: set) -> list:
    out = []
    if nt is None or nt.name_full in seen:
        return out
    seen.add(nt.name_full)
    for n in sorted(nt.nodes, key=lambda n: n.name):
        out.append((n.name, n.bl_idname))
        for p in n.bl_rna.properties:
            k = p.identifier
            if k in _SKIP or p.type == "COLLECTION":
                continue
            try:
                v = getattr(n, k)
            except (AttributeError, RuntimeError):
                continue
            if p.type == "POINTER":
                if k == "node_tree":
                    out.append(_tree(v, seen))
                elif v is not None and hasattr(v, "filepath"):  # an image
                    out.append((k, v.name_full, v.filepath, v.source, bool(getattr(v, "is_dirty", False))))
                continue
            out.append((k, _value(v)))
        for s in n.inputs:
            if hasattr(s, "default_value"):
                out.append((s.identifier, _value(s.default_value)))
    out.extend((ln.from_node.name, ln.from_socket.identifier, ln.to_node.name, ln.to_socket.identifier,
                ln.is_muted) for ln in nt.links)
    return out


def fingerprint(world) -> str:
    """What ``world``'s light depends on, as a string: its colour, and its node tree (every node's settings and
    socket values, images by name, path and unsaved edits, node groups inside, the links) as they are now."""
    return repr((world.name_full, _value(world.color), getattr(world, "use_nodes", True),
                 _tree(world.node_tree, set())))


def world_coefficients(world) -> np.ndarray:
    """4x3 L1 coefficients of ``world``'s light (model/sky.py ``coefficients``); zeros for a world that lights
    nothing, without a render. Kept for the world as it is (``fingerprint``): a later call for the same world
    makes no render."""
    global renders
    from . import passes

    if passes.world_is_black(world):
        return np.zeros((4, 3))
    key = fingerprint(world)
    if key not in _cache:
        renders += 1
        _cache[key] = sky_model.coefficients(world_env(world))
        while len(_cache) > CACHE_SIZE:
            _cache.pop(next(iter(_cache)))
    return _cache[key].copy()


def render_sky(scene, normals_cam: np.ndarray) -> np.ndarray:
    """HxWx3 float32: the sky group of ``scene`` for its camera-space normal pass ``normals_cam``."""
    from . import passes

    return sky_model.irradiance(world_coefficients(scene.world), normals_cam, passes.camera_rotation(scene))
