"""Tiny synthetic datasets in the real dataset format, for tests and smoke runs (bpy-free).

Not rendered: each sample is random axis-aligned rectangles of albedo / normal / depth, a direct-light
pattern with hard-edged "shadows", and a made-up reference with a non-local term a network can learn:

    ref = albedo * (direct + 0.6 * gaussian_blur(albedo * direct, sigma = 3 px) + 0.02)

The folder follows the dataset contract: ``manifest.json`` (format_version, blender_version, channel_spec,
settings, samples{key: seed, scene, camera, frame, timings}) and ``000000.exr`` ... written by exrio.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import channels as ch
from . import exrio, folder


def sample(w: int, h: int, seed: int, scene_seed: int) -> dict[str, np.ndarray]:
    from scipy.ndimage import gaussian_filter

    rs = np.random.default_rng(scene_seed)  # the scene: geometry and materials
    rl = np.random.default_rng(seed)  # this view's light
    albedo = np.full((h, w, 3), rs.uniform(0.3, 0.8, 3), np.float32)
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = 1
    depth = np.full((h, w, 1), rs.uniform(4, 8), np.float32)
    for _ in range(6):
        y0, x0 = rs.integers(0, h), rs.integers(0, w)
        y1, x1 = min(h, y0 + rs.integers(3, h // 2 + 4)), min(w, x0 + rs.integers(3, w // 2 + 4))
        albedo[y0:y1, x0:x1] = rs.uniform(0.05, 0.95, 3)
        n = rs.normal(size=3)
        n[2] = abs(n[2]) + 0.3
        normal[y0:y1, x0:x1] = n / np.linalg.norm(n)
        depth[y0:y1, x0:x1] = rs.uniform(1, 6)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    cx, cy = rl.uniform(0, w), rl.uniform(0, h)
    fall = 1.0 / (1.0 + ((xx - cx) ** 2 + (yy - cy) ** 2) / (0.3 * w) ** 2)
    direct = (rl.uniform(1, 3) * fall)[..., None] * np.maximum(normal[..., 2:3], 0) * np.ones(3, np.float32)
    for _ in range(3):  # hard shadows
        y0, x0 = rl.integers(0, h), rl.integers(0, w)
        direct[y0:y0 + rl.integers(2, h // 3 + 3), x0:x0 + rl.integers(2, w // 3 + 3)] = 0
    bounce = np.stack([gaussian_filter(albedo[..., c] * direct[..., c], 3) for c in range(3)], -1)
    world = np.full((h, w, 3), 0.02, np.float32)  # a dim uniform sky, unoccluded
    ref = albedo * (direct + 0.6 * bounce + world)
    lit = albedo * direct
    eevee = np.concatenate([lit, np.ones((h, w, 1), np.float32)], -1)
    ao = np.ones((h, w, 1), np.float32)
    return dict(albedo=albedo, normal=normal, depth=depth, direct=direct.astype(np.float32), ao=ao,
                world=world, eevee=eevee.astype(np.float32), ref=ref.astype(np.float32))


def with_emission(g: dict, seed: int) -> dict:
    """A sample of the diffuse-part format: an emissive patch (``emission``, zero albedo there), the diffuse part of
    the reference (``ref_diffuse``) and the whole reference = diffuse part + emission."""
    g = dict(g)
    h, w = g["albedo"].shape[:2]
    rs = np.random.default_rng(seed)
    em = np.zeros((h, w, 3), np.float32)
    y0, x0 = rs.integers(0, h - 2), rs.integers(0, w - 2)
    em[y0:y0 + 3, x0:x0 + 3] = rs.uniform(1, 4, 3)
    g["albedo"] = np.where(em.max(-1, keepdims=True) > 0, np.float32(0), g["albedo"]).astype(np.float32)
    g["ref_diffuse"] = (g["ref"] * (g["albedo"] > 0)).astype(np.float32)
    g["emission"] = em
    g["ref"] = (g["ref_diffuse"] + em).astype(np.float32)
    return g


def with_rest(g: dict, seed: int, eevee_share: float = 0.3) -> dict:
    """``with_emission`` and EEVEE's ``rest``: Cycles' image also holds a glossy glow around the emitter on the
    diffuse-coloured surfaces, of which EEVEE's rest renders only ``eevee_share`` (as EEVEE's rough reflections
    miss an emissive lamp shade, docs/fit.md); the emission itself is in both."""
    g = with_emission(g, seed)
    h, w = g["albedo"].shape[:2]
    em = g["emission"].max(-1)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    cy, cx = (np.argwhere(em > 0).mean(0) if (em > 0).any() else (h / 2, w / 2))
    glow = (0.3 / (1.0 + ((yy - cy) ** 2 + (xx - cx) ** 2) / (0.2 * w) ** 2))[..., None] * np.ones(3, np.float32)
    glow = (glow * (g["albedo"].max(-1, keepdims=True) > 0)).astype(np.float32)
    g["ref"] = (g["ref"] + glow).astype(np.float32)
    g["rest"] = (g["emission"] + eevee_share * glow).astype(np.float32)
    return g


def with_shipped_inputs(g: dict, seed: int) -> dict:
    """``with_emission`` and the other groups the shipped default model reads: softened direct light, the light of
    emitters and the surround occupancy (random, in [0, 1])."""
    g = with_emission(g, seed)
    h, w = g["albedo"].shape[:2]
    rs = np.random.default_rng(seed + 1)
    g["direct_soft"] = (0.8 * g["direct"]).astype(np.float32)
    g["emit_direct"] = (0.1 * g["emission"].max(-1, keepdims=True) * g["albedo"]).astype(np.float32)
    g["surround"] = rs.uniform(0, 1, (h, w, len(ch.GROUPS["surround"].channels))).astype(np.float32)
    return g


SHIPPED_GROUPS = ("emission", "ref_diffuse", "direct_soft", "emit_direct", "surround")


def make_dataset(root, scenes: int = 4, per_scene: int = 2, w: int = 48, h: int = 32, seed: int = 0,
                 half: bool = False, emission: bool = False, rest: bool = False, shipped: bool = False) -> Path:
    """Write a synthetic dataset folder; returns its path. With ``emission``, the samples hold the groups of the
    diffuse-part bakes too (``with_emission``), so models trained on it learn the diffuse part; with ``rest`` also
    EEVEE's rest, which misses part of Cycles' glossy light (``with_rest``); with ``shipped`` every group the shipped
    default model reads (``with_shipped_inputs``)."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    samples = {}
    k = 0
    for s in range(scenes):
        for v in range(per_scene):
            key = folder.sample_name(k)
            sd = seed * 100003 + k
            g = sample(w, h, sd, seed * 1009 + s)
            g = (with_shipped_inputs(g, sd) if shipped else with_rest(g, sd) if rest else with_emission(g, sd)
                 if emission else g)
            exrio.write_sample(folder.sample_path(root, key), g, half=half)
            samples[key] = dict(seed=sd, scene=f"synthetic-{seed}-{s}", camera=v, frame=1, timings={})
            k += 1
    m = folder.new_manifest(dict(size=[w, h], ref_samples=0, denoise=False, synthetic=True), "synthetic",
                            groups=tuple(sample(2, 2, 0, 0)) + (SHIPPED_GROUPS if shipped else ("emission", "ref_diffuse")
                                                                if emission or rest else ())
                            + (("rest",) if rest else ()))
    m["samples"] = samples
    folder.write_manifest(root, m)
    return root
