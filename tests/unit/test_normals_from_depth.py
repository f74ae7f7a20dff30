"""model/images.normals_from_depth: the render path's camera-space normals from EEVEE's Z pass, where its
one render writes no Normal pass (passes.render_gbuffer). Depth images made by intersecting each pixel's ray with
known planes: the normals must be the planes' own, beside silhouettes too, and zero where nothing was hit."""
from __future__ import annotations

import numpy as np
import pytest

from model.images import DEPTH_BACKGROUND, normals_from_depth

W, H = 64, 36


def perspective(fx=1.2, aspect=W / H):
    """A Blender-style OpenGL projection (calc_matrix_camera's layout), with a small lens shift."""
    return np.array([[fx, 0, 0.03, 0], [0, fx * aspect, -0.02, 0], [0, 0, -1.002, -0.2], [0, 0, -1, 0]], np.float64)


def orthographic(scale=0.25):
    return np.array([[scale, 0, 0, 0.05], [0, scale * W / H, 0, 0], [0, 0, -0.01, -1.0], [0, 0, 0, 1]], np.float64)


def rays(P):
    """Per pixel (origin, direction) in camera space, the unprojection normals_from_depth inverts (depth = -z)."""
    nx = (np.arange(W) + 0.5) / W * 2.0 - 1.0
    ny = 1.0 - (np.arange(H) + 0.5) / H * 2.0
    nx, ny = np.meshgrid(nx, ny)
    if P[3, 3] == 0.0:
        d = np.stack([(nx + P[0, 2]) / P[0, 0], (ny + P[1, 2]) / P[1, 1], -np.ones_like(nx)], -1)
        return np.zeros_like(d), d
    o = np.stack([(nx - P[0, 3]) / P[0, 0], (ny - P[1, 3]) / P[1, 1], np.zeros_like(nx)], -1)
    return o, np.broadcast_to(np.array([0.0, 0.0, -1.0]), o.shape)


def plane_depth(P, n, c):
    """Depth (along the view axis) of the plane n.x = c hit by each pixel's ray; inf where it is missed / behind."""
    o, d = rays(P)
    n = np.asarray(n, np.float64) / np.linalg.norm(n)
    t = (c - o @ n) / (d @ n)
    z = -(o[..., 2] + t * d[..., 2])
    return np.where((t > 0) & np.isfinite(t), z, np.inf), n


@pytest.mark.parametrize("proj", [perspective(), orthographic()], ids=["perspective", "orthographic"])
def test_a_tilted_plane_gets_its_own_normal_everywhere(proj):
    z, n = plane_depth(proj, (0.3, -0.5, 0.8), -4.0)
    assert np.isfinite(z).all() and (z > 0).all()
    got = normals_from_depth(z[..., None].astype(np.float32), proj)
    assert got.shape == (H, W, 3) and got.dtype == np.float32
    facing = n if n[2] > 0 else -n
    assert np.abs(got - facing).max() < 2e-3, np.abs(got - facing).max()
    assert np.allclose(np.linalg.norm(got, axis=-1), 1.0, atol=1e-5)


def test_pixels_beside_a_silhouette_take_their_own_surface_and_the_background_is_zero():
    P = perspective()
    wall, nw = plane_depth(P, (0.0, 0.0, 1.0), -6.0)        # a wall facing the camera, 6 m away
    box, nb = plane_depth(P, (0.6, 0.0, 0.8), -3.0)          # a face turned to the right, 3 m away
    cols = np.arange(W)[None, :].repeat(H, 0)
    z = np.where(cols < 30, box, wall)                      # the face covers the left half: a depth jump at x = 30
    z[:4] = 1e10                                            # the top rows see nothing
    z[4:6] = 100.02                                         # nor these: EEVEE's Z pass writes about the clip end there
    got = normals_from_depth(z, P, clip_end=100.0)
    assert np.all(got[:6] == 0.0)
    assert (np.abs(normals_from_depth(z, P)[4:6]).sum(-1) > 0.5).all()  # a plane at 100 m, without the clip end
    assert np.abs(got[6:, :30] - nb).max() < 2e-3           # up to the last pixel before the jump
    assert np.abs(got[6:, 30:] - nw).max() < 2e-3           # from the first pixel after it
    assert DEPTH_BACKGROUND < 1e10


def test_a_sphere_seen_by_the_camera_gets_the_normals_of_its_surface():
    P = perspective()
    o, d = rays(P)
    c, r = np.array([0.2, -0.1, -5.0]), 1.5
    dn = d / np.linalg.norm(d, axis=-1, keepdims=True)
    b = np.einsum("...i,i->...", dn, -c)
    disc = b * b - (c @ c - r * r)
    t = -b - np.sqrt(np.maximum(disc, 0))                   # nearest hit along the unit ray
    hit = disc > 0
    pts = dn * t[..., None]
    z = np.where(hit, -pts[..., 2], np.inf)
    want = (pts - c) / r
    got = normals_from_depth(z, P)
    inner = hit.copy()  # away from the rim, where one-sided differences still see the sphere on both sides
    for ax in (0, 1):
        inner &= np.roll(hit, 1, ax) & np.roll(hit, -1, ax)
    ang = np.degrees(np.arccos(np.clip(np.einsum("...i,...i->...", got, want)[inner], -1, 1)))
    # a one-sided difference is the slope half a pixel away: on this 28-px-wide sphere a pixel spans ~7 degrees of
    # its surface, so the normals are ~3-4 degrees off (measured: median 2.8, max 4.6); a swapped axis or sign is 90+
    assert inner.sum() > 200 and np.median(ang) < 4.0 and ang.max() < 8.0, (np.median(ang), ang.max())
    assert np.all(got[~hit] == 0.0)


def test_a_too_small_image_is_refused():
    with pytest.raises(ValueError, match="1x5"):
        normals_from_depth(np.ones((5, 1)), perspective())
