"""The ``sky`` input group (model/channels.py): the world's unoccluded light on each surface, from the normal alone.

EEVEE lights a diffuse surface from the world with the world's first-order spherical harmonics (L1) evaluated at
the surface normal: a least-squares L1 fit to EEVEE's own world pass (``passes.render_world``) leaves 0.1-0.2 % of
it on the artist test set's exterior and living room (docs/one_render.md). So the light the world
brings, unoccluded, is four RGB coefficients of the world and the normal pass: no render of the scene. The
coefficients come from a small equirectangular image of the world (ssgi_addon/blender/sky.py renders it with
Cycles); everything here is numpy.

Conventions: the equirectangular image is top row first; its centre looks along the panoramic camera's view
(world -Z for a camera with rotation 0), its columns turn towards the camera's right as they go right, its rows
run from the camera's up (top) to its down (bottom); ``equirect_directions`` gives each pixel's direction in the
world. Values are what a Diffuse Direct pass holds: irradiance / pi (a white world of strength 1 gives 1.0).
"""
from __future__ import annotations

import numpy as np

Y0 = 0.282095  # the constant real spherical harmonic, 1 / (2 sqrt(pi))
Y1 = 0.488603  # the linear ones' factor, sqrt(3 / (4 pi))


def equirect_directions(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """(HxWx3 unit directions in world space, HxW solid angle of each pixel) of an equirectangular image made by a
    panoramic camera with rotation 0 (Blender's camera looks along its -Z: the image's centre is world -Z)."""
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    lon = (u - 0.5) * 2.0 * np.pi
    lat = (0.5 - v) * np.pi
    fwd, right, up = np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)
    # the camera's right is world +X, its up world +Y, its view world -Z (measured against EEVEE's world pass)
    d = np.stack([right, up, -fwd], axis=-1)
    edges = np.pi * (0.5 - np.arange(h + 1) / h)  # the rows' latitudes at their top and bottom: exact solid angles
    solid = np.broadcast_to(((np.sin(edges[:-1]) - np.sin(edges[1:])) * 2.0 * np.pi / w)[:, None], (h, w))
    return d, solid


def coefficients(env: np.ndarray) -> np.ndarray:
    """4x3 coefficients (constant, then world x, y, z; RGB columns) of the irradiance / pi that the world ``env``
    (HxWx3 equirectangular radiance, ``equirect_directions``' layout) casts on a surface, in the L1 basis: the
    radiance's projection times the cosine lobe's factors (pi, 2 pi / 3; Ramamoorthi and Hanrahan 2001), over pi."""
    env = np.nan_to_num(np.asarray(env, np.float64)[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
    d, solid = equirect_directions(*env.shape[:2])
    basis = np.concatenate([np.full(d.shape[:2] + (1,), Y0), Y1 * d], axis=-1)
    proj = np.einsum("hwk,hwc,hw->kc", basis, env, solid)
    return proj * np.array([1.0, 2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0])[:, None]


def irradiance(coef: np.ndarray, normals_cam: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """HxWx3 float32: the world's unoccluded light on each pixel's surface (irradiance / pi, >= 0) from the L1
    coefficients ``coef`` (``coefficients``) and camera-space normals (HxWx3, zero where nothing is hit: 0 there).
    ``rot``: the camera's rotation, its columns the camera's axes in the world (passes.camera_rotation)."""
    n = np.asarray(normals_cam, np.float64)
    lin = np.asarray(rot, np.float64).T @ np.asarray(coef, np.float64)[1:]  # the linear part in camera space
    e = Y0 * coef[0] + Y1 * np.einsum("hwi,ic->hwc", n, lin)
    hit = np.linalg.norm(n, axis=-1, keepdims=True) > 0.5
    return np.where(hit, np.maximum(e, 0.0), 0.0).astype(np.float32)
