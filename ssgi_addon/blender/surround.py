"""The ``surround`` input group (model/channels.py): what lies around the camera, on screen or not.

The network sees only the screen, and a closed room and an open, dark stage look alike there when the walls
that bounce light into the frame are behind or beside the camera: the shipped model lit the artist test set's
studio like a room and its closed room like a stage (docs/artist_rooms.md). This group casts rays from the camera
into the scene's geometry (``Scene.ray_cast`` on the evaluated depsgraph: meshes, curves and modifiers as
rendered; lights and the world are not geometry) in ``N_RAYS`` fixed directions of a Fibonacci sphere in camera
space, bins each ray by its nearest camera axis (right, left, up, down, front = the view direction, back), and
keeps per bin the share of rays that hit nothing within the camera's clip end ("open") and the mean of
m / (d + m) ("near": 0 for a miss), d the hit distance and m the median of all the hit distances, so that the
values do not depend on the scene's scale. 12 numbers, broadcast over the image; a few ms of CPU per frame.

It is geometry only: a wall's colour, and objects hidden from the viewport but not the render, are not seen
(ray_cast sees what the depsgraph evaluates).
"""
from __future__ import annotations

import math

import numpy as np
from mathutils import Vector

from ...model import channels as ch

N_RAYS = 256
_AXES = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, -1), (0, 0, 1)], np.float64)  # R L U D F B


def directions(n: int = N_RAYS) -> np.ndarray:
    """n x 3 unit vectors of a Fibonacci sphere (camera space: +X right, +Y up, -Z the view direction)."""
    i = np.arange(n, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def bins(dirs: np.ndarray) -> np.ndarray:
    """The bin (index into channels.SURROUND_BINS) of each direction: its nearest camera axis."""
    return np.argmax(dirs @ _AXES.T, axis=1)


def features(dist: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """The 12 values from hit distances (inf: a miss) of rays ``dirs``: per bin open share, then nearness."""
    hit = np.isfinite(dist)
    # (a camera on a surface hits at 0: the floor of m keeps m / (d + m) finite, 1 for those rays)
    m = max(float(np.median(dist[hit])), 1e-6) if hit.any() else 1.0
    near = np.where(hit, m / (np.where(hit, dist, 0.0) + m), 0.0)
    b = bins(dirs)
    out = np.zeros(len(ch.SURROUND_COMPONENTS), np.float32)
    for k in range(len(ch.SURROUND_BINS)):
        sel = b == k
        if sel.any():
            out[2 * k] = 1.0 - hit[sel].mean()
            out[2 * k + 1] = near[sel].mean()
    return out


def _depsgraph(scene):
    import bpy
    if bpy.context.scene == scene:
        return bpy.context.evaluated_depsgraph_get()
    dg = scene.view_layers[0].depsgraph
    dg.update()
    return dg


def hit_distances(scene, dirs: np.ndarray, camera=None) -> np.ndarray:
    """Distance from ``camera`` (default the scene's) to the first hit along each camera-space direction of
    ``dirs`` (n x 3), inf where nothing is hit within the camera's clip end."""
    cam = camera or scene.camera
    dg = _depsgraph(scene)
    mw = cam.evaluated_get(dg).matrix_world
    origin = mw.to_translation()
    rot = mw.to_quaternion().to_matrix()
    far = float(cam.data.clip_end)
    dist = np.full(len(dirs), np.inf)
    for i, d in enumerate(dirs):
        hit, loc, *_ = scene.ray_cast(dg, origin, rot @ Vector(d), distance=far)
        if hit:
            dist[i] = (loc - origin).length
    return dist


def probe(scene, camera=None) -> np.ndarray:
    """The surround group's 12 values for ``scene`` seen from ``camera`` (default the scene's camera)."""
    dirs = directions()
    return features(hit_distances(scene, dirs, camera), dirs)


def render_surround(scene, camera=None) -> np.ndarray:
    """HxWx12 float32: ``probe`` broadcast over the scene's render size."""
    r = scene.render
    w = max(1, r.resolution_x * r.resolution_percentage // 100)
    h = max(1, r.resolution_y * r.resolution_percentage // 100)
    return np.ascontiguousarray(np.broadcast_to(probe(scene, camera), (h, w, len(ch.SURROUND_COMPONENTS))))
