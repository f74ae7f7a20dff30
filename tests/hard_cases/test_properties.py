"""Hard case 11: property-based tests (hypothesis) of the normalisation, the tonemap and its
inverse, the light transform, tiling, and the channel-spec parser, over random shapes and values.

Example counts are bounded and deadlines off, so the file stays fast on a loaded 2-core machine."""
from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ssgi.model import channels as ch
from ssgi.model.learn import network
from ssgi.model.infer import predictor
from ssgi.model import metrics, normalize
from ssgi.model.infer.bench import synthetic_groups
from ssgi.model.errors import UserError

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SLOW = settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
ANY32 = st.floats(allow_nan=True, allow_infinity=True, width=32)
specs = st.lists(st.sampled_from(ch.INPUT_GROUPS), min_size=1, max_size=len(ch.INPUT_GROUPS), unique=True).map(tuple)
EPS = np.finfo(np.float64).eps


@st.composite
def scenes(draw, max_side=9, elements=ANY32):
    """Random raw groups (every stored input group) of one random size, any float32 values."""
    h, w = draw(st.integers(1, max_side)), draw(st.integers(1, max_side))
    return {g: draw(arrays(np.float32, (h, w, ch.GROUPS[g].size), elements=elements))
            for g in ch.SAMPLE_GROUPS if g in ch.INPUT_GROUPS}  # albedo normal depth direct ao world


# ------------------------------------------------------------------------------------------- normalisation

@FAST
@given(g=scenes(), spec=specs)
def test_inputs_are_finite_in_range_and_count_repaired_pixels(g, spec):
    """Case 11: for any input spec and any values (NaN, Inf, huge, negative), to_inputs gives an HxWxC
    float32 array with C from the channel spec, finite, each group in its documented range, and counts as
    repaired the pixels with a non-finite value in any group it reads (normal included when depth uses it)."""
    h, w = g["albedo"].shape[:2]
    x, n = normalize.to_inputs(g, spec)
    assert x.shape == (h, w, ch.input_channels(spec)) and x.dtype == np.float32
    assert np.isfinite(x).all()
    lay = normalize.layout(spec)
    lo_hi = {"color": (0, 1), "unit": (0, 1), "normal": (-1, 1), "depth": (0, 1), "light": (0, np.log1p(65504.0))}
    for name, sl in lay.items():
        kind = ch.GROUPS[name].kind if name in ch.GROUPS else "light"
        lo, hi = lo_hi[kind]
        assert x[..., sl].min() >= lo and x[..., sl].max() <= np.float32(hi), name
    read = set(ch.required_groups(spec)) | ({"normal"} if "depth" in spec else set())
    bad = np.zeros((h, w), bool)
    for name in read:
        bad |= ~np.isfinite(g[name]).all(axis=-1)
    assert n == int(bad.sum())


@FAST
@given(g=scenes(elements=st.floats(-1e6, 1e6, width=32)), spec=specs)
def test_normalisation_commutes_with_the_mirror(g, spec):
    """Case 11: mirroring the raw passes (normal.x negated) and then normalising equals normalising and then
    mirroring with normalize.flip_x: the flip augmentation is the same scene seen in a mirror."""
    m = {k: v[:, ::-1].copy() for k, v in g.items()}
    m["normal"][..., 0] *= -1
    if "surround" in m:  # in a mirror, what was on the camera's right is on its left
        comps = ch.SURROUND_COMPONENTS
        m["surround"] = m["surround"][..., [comps.index({"R": "L", "L": "R"}.get(c[0], c[0]) + c[1:]) for c in comps]]
    a = normalize.flip_x(normalize.to_inputs(g, spec)[0], spec)
    b = normalize.to_inputs(m, spec)[0]
    np.testing.assert_array_equal(a, b)


@FAST
@given(z=arrays(np.float32, st.tuples(st.integers(1, 8), st.integers(1, 8), st.just(1)),
                elements=st.floats(0.0010000000474974513, 1e5, width=32)),
       scale=st.floats(1e-3, 1e3))
def test_depth_normalisation_is_scale_free_and_monotone(z, scale):
    """Case 11: depth normalisation of geometry at depths 0.001 .. 1e5 is in (0, 1], below 1 (background)
    wherever the depth is under 1e7 times the image's median (float32 rounds z / (z + m) to 1 beyond), the
    same for the scene scaled by any factor (a clip range of 0.001 or 1e5 changes nothing), and keeps the
    order of depths."""
    assume(float(np.max(z) * scale) < normalize.DEPTH_BACKGROUND)
    a = normalize.depth_normalise(z)[..., 0]
    b = normalize.depth_normalise((z.astype(np.float64) * scale).astype(np.float32))[..., 0]
    assert np.isfinite(a).all() and (a > 0).all() and (a <= 1).all()
    assert (a[z[..., 0] < 1e7 * np.median(z)] < 1).all()
    np.testing.assert_allclose(a, b, atol=2e-6)
    order = np.argsort(z.ravel(), kind="stable")
    assert (np.diff(a.ravel()[order]) >= 0).all()


# ------------------------------------------------------------------------------------------- tonemap, light

@FAST
@given(x=arrays(np.float64, st.tuples(st.integers(1, 6), st.integers(1, 6)),
                elements=st.floats(0, 1e6, allow_subnormal=False)))
def test_tonemap_and_its_inverse(x):
    """Case 11: the Reinhard tonemap maps [0, inf) into [0, 1) monotonically, and its inverse gives x back
    to float64 rounding amplified by (1 + x)^2 (the slope of y/(1-y))."""
    y = metrics.tonemap(x)
    assert ((y >= 0) & (y < 1)).all()
    order = np.argsort(x.ravel())
    assert (np.diff(y.ravel()[order]) >= 0).all()
    back = metrics.inverse_tonemap(y)
    assert (np.abs(back - x) <= 4 * EPS * (1 + x) ** 2).all()


@FAST
@given(v=st.floats(allow_nan=True, allow_infinity=True))
@example(v=2.0 ** 53 - 1)
@example(v=2.0 ** 53)      # 1 + x rounds back to x: y == 1
@example(v=2.0 ** 53 + 2)  # 1 + x rounds up to x + 4 (ties to even): y == 1 - 2^-52, CI found it
@example(v=float(np.finfo(np.float64).max))
def test_tonemap_of_any_float_is_defined(v):
    """Case 11: NaN and negative values tonemap to 0, +Inf to 1, every finite x > 0 into (0, 1].

    What float64 guarantees for y = x / (1 + x): below 2^53, 1 + x is exact or rounds up and the true
    1 - 1/(1 + x) <= 1 - 2^-53 is representable, so y < 1. From 2^53 on, 1 + x rounds to x or to x + ulp(x)
    (ties to even), so y is 1 or the true x / (x + ulp) > 1 - 2^-52 rounded: either way y >= 1 - 2^-52."""
    y = float(metrics.tonemap(np.array([v]))[0])
    if np.isnan(v) or v <= 0:
        assert y == 0.0
    elif np.isinf(v):
        assert y == 1.0
    elif v < 2.0 ** 53:
        assert 0.0 < y < 1.0  # 1 + x == 1 for tiny x, and then y == x > 0
    else:
        assert 1.0 - 2.0 ** -52 <= y <= 1.0
    assert float(metrics.inverse_tonemap(np.array([y]))[0]) >= 0


@FAST
@given(x=arrays(np.float32, st.tuples(st.integers(1, 5), st.integers(1, 5), st.integers(1, 3)),
                elements=st.floats(0, 65504, width=32)))
def test_light_transform_numpy_and_torch_agree_and_invert(x):
    """Case 11: the light transform log1p and its inverse expm1 agree between numpy and torch, and invert
    each other in float32 to a few ulps over the whole half-float range of light."""
    f_np = normalize.light_forward(x)
    f_t = normalize.light_forward(torch.from_numpy(x)).numpy()
    np.testing.assert_allclose(f_np, f_t, rtol=2e-6, atol=1e-7)
    np.testing.assert_allclose(normalize.light_inverse(f_np), x, rtol=2e-6, atol=1e-6)
    np.testing.assert_allclose(normalize.light_inverse(torch.from_numpy(f_np)).numpy(), x, rtol=2e-6, atol=1e-6)


# ------------------------------------------------------------------------------------------- tiling

_NETS: dict = {}


def _net(variant: str):
    if variant not in _NETS:
        torch.manual_seed(0)
        arch = {"width": 8, "pre": 2, "post": 2} if variant.startswith("fssgi") else {}
        _NETS[variant] = network.build(network.arch_for(variant, ch.DEFAULT_INPUTS, **arch)).eval()
    return _NETS[variant]


@SLOW
@given(variant=st.sampled_from(["fssgi", "unet_s", "unet"]), h=st.integers(1, 45), w=st.integers(1, 45),
       tile=st.integers(8, 24), seed=st.integers(0, 2**16))
def test_tiled_forward_equals_untiled_for_any_size_and_tile(variant, h, w, tile, seed):
    """Case 11: for random image sizes and tile sizes, the tiled forward pass equals the untiled one to
    float32 summation-order noise, for stride-1 and stride-2 (U-Net) networks alike."""
    net = _net(variant)
    g = synthetic_groups(w, h, seed)
    g["direct"] *= np.float32(10.0 ** (seed % 7 - 2))  # 0.01 .. 1e4
    x = torch.from_numpy(normalize.to_inputs(g, ch.DEFAULT_INPUTS)[0]).permute(2, 0, 1)[None].contiguous()
    with torch.inference_mode():
        full = net(x)
        tiled = predictor.tiled_forward(net, x, tile=tile)
    assert tiled.shape == full.shape == (1, 3, h, w)
    torch.testing.assert_close(tiled, full, rtol=1e-4, atol=1e-5)


# ------------------------------------------------------------------------------------------- channel spec

NAME = st.one_of(st.sampled_from(ch.INPUT_GROUPS), st.sampled_from(["", "ref", "eevee", "position", "Albedo"]),
                 st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=8))
SPACE = st.sampled_from(["", " ", "  ", "\t"])


@FAST
@given(names=st.lists(st.tuples(SPACE, NAME, SPACE), min_size=0, max_size=8), as_string=st.booleans())
def test_parse_spec_accepts_exactly_the_valid_specs(names, as_string):
    """Case 11: parse_spec accepts a list or comma-separated string iff it names at least one group, each a
    known input group, none twice (whitespace around names is ignored), and returns the names in order; a
    valid spec survives format_spec -> parse_spec; an invalid one is a UserError that names the fault."""
    raw = [a + n + b for a, n, b in names]
    clean = [n for _, n, _ in names]
    arg = ",".join(raw) if as_string else raw
    valid = bool(clean) and all(n in ch.INPUT_GROUPS for n in clean) and len(set(clean)) == len(clean)
    if valid:
        spec = ch.parse_spec(arg)
        assert spec == tuple(clean)
        assert ch.parse_spec(ch.format_spec(spec)) == spec
        assert ch.input_channels(spec) == sum(ch.group_size(n) for n in spec)
        return
    with pytest.raises(UserError) as e:
        ch.parse_spec(arg)
    msg = str(e.value)
    if not clean or clean == [""]:
        assert "empty" in msg
    else:
        bad = next(n for i, n in enumerate(clean) if n == "" or n not in ch.INPUT_GROUPS or n in clean[:i])
        assert "empty" in msg or repr(bad) in msg, (clean, msg)
