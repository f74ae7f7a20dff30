"""model/sky.py: the world's unoccluded light on a surface from the world's L1 spherical harmonics and the normal."""
from __future__ import annotations

import numpy as np

from ssgi.model import channels as ch, sky

H, W = 64, 128


def _env(fn) -> np.ndarray:
    d, _ = sky.equirect_directions(H, W)
    return np.repeat(fn(d)[..., None], 3, axis=-1).astype(np.float32)


def _n(*v) -> np.ndarray:
    return np.asarray(v, np.float64).reshape(1, 1, 3)


def test_the_equirect_layout_is_the_panoramic_camera_s_view_right_and_up():
    d, solid = sky.equirect_directions(H, W)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
    assert abs(solid.sum() - 4 * np.pi) < 1e-3  # the whole sphere
    centre = d[H // 2 - 1:H // 2 + 1, W // 2 - 1:W // 2 + 1].mean((0, 1))
    np.testing.assert_allclose(centre / np.linalg.norm(centre), (0, 0, -1), atol=1e-3)  # world -Z
    assert d[0, W // 2, 1] > 0.99  # the top row: the camera's up, world +Y
    assert d[H // 2, 3 * W // 4, 0] > 0.99  # three quarters across: the camera's right, world +X


def test_a_uniform_white_world_lights_every_normal_at_its_radiance():
    c = sky.coefficients(_env(lambda d: np.full(d.shape[:2], 2.0)))
    rot = np.eye(3)
    for n in [(0, 0, 1), (1, 0, 0), (0, -1, 0), (0.6, 0.0, -0.8)]:
        np.testing.assert_allclose(sky.irradiance(c, _n(*n), rot)[0, 0], 2.0, rtol=2e-3)


def test_a_world_lit_from_one_side_lights_the_normals_facing_it_and_not_the_others():
    # radiance 1 on the +Y half of the sphere: exact irradiance / pi is 1 facing it, 0 facing away, 1/2 edge-on;
    # the L1 approximation is exact at those three
    c = sky.coefficients(_env(lambda d: (d[..., 1] > 0).astype(float)))
    rot = np.eye(3)
    assert abs(sky.irradiance(c, _n(0, 1, 0), rot)[0, 0, 0] - 1.0) < 0.01
    assert abs(sky.irradiance(c, _n(0, -1, 0), rot)[0, 0, 0]) < 0.01
    assert abs(sky.irradiance(c, _n(1, 0, 0), rot)[0, 0, 0] - 0.5) < 0.01


def test_camera_space_normals_are_turned_into_the_world_by_the_camera_s_rotation():
    c = sky.coefficients(_env(lambda d: (d[..., 2] > 0).astype(float)))  # lit from world +Z
    # a camera looking along world +Y with world +Z up: its columns (its X, Y, Z axes in the world)
    rot = np.stack([[1, 0, 0], [0, 0, 1], [0, -1, 0]], axis=1).astype(float)
    assert np.allclose(rot @ (0, 1, 0), (0, 0, 1))  # the camera's up is world +Z
    up = sky.irradiance(c, _n(0, 1, 0), rot)[0, 0, 0]
    towards_camera = sky.irradiance(c, _n(0, 0, 1), rot)[0, 0, 0]
    assert abs(up - 1.0) < 0.01 and abs(towards_camera - 0.5) < 0.01
    assert abs(sky.irradiance(c, _n(0, 1, 0), np.eye(3))[0, 0, 0] - 0.5) < 0.01  # the wrong rotation: edge-on


def test_nothing_hit_is_dark_light_is_never_negative_and_bad_values_in_the_world_are_ignored():
    env = _env(lambda d: 5.0 * (d[..., 0] > 0.9))  # a small bright patch: L1 rings negative on the far side
    env[0, 0] = np.nan
    env[1, 1] = np.inf
    c = sky.coefficients(env)
    assert np.isfinite(c).all()
    n = np.zeros((2, 2, 3))
    n[0, 0] = (-1, 0, 0)
    n[1, 1] = (1, 0, 0)
    e = sky.irradiance(c, n, np.eye(3))
    assert e.dtype == np.float32 and e.shape == (2, 2, 3)
    assert (e >= 0).all() and e[0, 1].max() == 0 and e[1, 0].max() == 0  # zero normals: nothing hit
    assert e[1, 1, 0] > 0.2 and e[0, 0, 0] == 0.0


def test_the_group_is_an_optional_light_input():
    g = ch.GROUPS["sky"]
    assert g.kind == "light" and g.channels == ("sky.R", "sky.G", "sky.B")
    assert "sky" in ch.INPUT_GROUPS and "sky" in ch.OPTIONAL_GROUPS
    assert ch.required_groups(ch.parse_spec("albedo,normal,sky")) == ("albedo", "normal", "sky")
