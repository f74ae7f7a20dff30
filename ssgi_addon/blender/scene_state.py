"""Putting a scene back: ``preserved(scene)`` snapshots every plain setting of the scene, its render / EEVEE /
colour settings, view layers, light data, light probes and world, and restores them on exit (the render path
changes engine, passes and output format for its pass render and its composite)."""
from __future__ import annotations

import contextlib

import bpy

_SIMPLE = {"BOOLEAN", "INT", "FLOAT", "STRING", "ENUM"}


def _snapshot(struct) -> dict:
    out = {}
    for p in struct.bl_rna.properties:
        if p.is_readonly or p.identifier == "rna_type":
            continue
        if p.type in _SIMPLE or (p.type == "POINTER" and isinstance(getattr(struct, p.identifier, None), bpy.types.ID)):
            try:
                v = getattr(struct, p.identifier)
            except AttributeError:
                continue
            if p.type in ("INT", "FLOAT", "BOOLEAN") and getattr(p, "array_length", 0):
                v = tuple(v)
            out[p.identifier] = v
    return out


def _restore(struct, saved: dict) -> None:
    for k, v in saved.items():
        try:
            cur = getattr(struct, k)
            if isinstance(v, tuple):
                cur = tuple(cur)
            if cur != v:
                setattr(struct, k, v)
        except (AttributeError, TypeError, ValueError, RuntimeError):
            pass  # read-only in this state, or an enum item that no longer exists: leave it


def _structs(scene) -> list:
    r = scene.render
    out = [scene, r, r.image_settings, scene.eevee, scene.view_settings, scene.display_settings]
    out += list(scene.view_layers)
    out += list({o.data for o in scene.objects if o.type == "LIGHT"})
    out += [o for o in scene.objects if o.type == "LIGHT_PROBE"]
    if scene.world is not None:
        out.append(scene.world)
    return out


@contextlib.contextmanager
def preserved(scene):
    """Put back every plain setting of the scene, its render/EEVEE/colour settings, view layers, light data and
    world on exit, and the current frame."""
    frame = scene.frame_current
    saved = [(s, _snapshot(s)) for s in _structs(scene)]
    # image_settings is restored twice: a file format change resets colour depth/codec, so format first
    try:
        yield
    finally:
        for s, v in saved:
            _restore(s, v)
        _restore(scene.render.image_settings, saved[2][1])
        if scene.frame_current != frame:
            scene.frame_set(frame)
