"""Rendering passes into numpy: EEVEE's direct-only G-buffer, and Cycles (reference or diffuse direct).

Contract (used by the baker and the compositor node):

- ``configure_gbuffer(scene, groups)`` enables the view-layer passes that ``groups`` need and sets EEVEE up for
  direct light only (no ray tracing, no fast GI, light threshold 0, lights' custom distance large).
- ``render_gbuffer(scene, groups=None) -> {group: HxWxC float32}``: renders EEVEE with a world that lights
  nothing (camera rays still see it, so the Combined pass keeps the sky), light probes hidden and hard lights
  (point/spot radius 0, sun angle 0, area lights shrunk to ~1 cm keeping their aspect), restores all of that
  afterwards, and returns the groups top row first with normals in CAMERA space. Asked for ``rest`` at the
  same samples (the render path), it reads albedo, normal, depth and emission from that artist-settings render
  (``SHARED_GROUPS``: bit-identical, docs/one_render.md); ``last_timings`` has each render's seconds. That
  render writes no Emission pass where no used material can emit (zeros, exact), and a
  one-render model's frame writes no Normal pass: its normals come from the Z pass (``last_render``).
- ``render_cycles(scene, samples, seed, ...)``: Cycles with the lights at their real radius (the reference),
  or with hard lights and point-sampled pixels (to check EEVEE's 1-sample Diffuse Direct pass against Cycles').

Pixels are read by saving the render result as a multilayer EXR (the only way that works in background mode,
see docs/bake.md) and reading every part with OpenEXR.

Why one module of ~590 lines: the G-buffer and the Cycles renders share its scene overrides (the world that
lights nothing, hard lights, point-sampled pixels) and the EXR read-back; apart, each half would import the
other's private helpers. Its temporary-file sweeper goes once model/files.py owns the one sweeper.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
import time

import bpy
import numpy as np

from ...model import channels as ch, files
from ...model.errors import UserError

# group -> Blender render pass name (the channel spec's Group.render_pass)
PASS_NAMES: dict[str, str] = {g.name: g.render_pass for g in ch.GROUPS.values() if g.render_pass}
# groups the artist-settings render gives besides rest, those of a one-render model's one render (docs/one_render.md):
# eevee_local, its Diffuse Direct pass (what a rest needs too), and eevee_combined, its Combined image (RGB), the
# input of one-render models (target ref_combined)
DIFFUSE_LIGHT_GROUPS = ("eevee_local",)
REST_LIGHT_GROUPS = DIFFUSE_LIGHT_GROUPS + ("eevee_combined",)
# How the one render is made: ray tracing and fast GI off, an area light standing in for each planar emitter
# (a frame without EEVEE's GI: the network's GI replaces it, and EEVEE lights nothing from an emitter without its
# GI). Its proxies cast no shadow: on Mesa their shadows cost the Cornell shot's 960x540 frame 0.88 s of 10.87 at 16
# samples (benchmarks/pass_cost.py), and EEVEE's soft shadows at 16 samples are noisy where the network passed the
# noise on; the network and the shot's lightmap put the shadows back: withheld frames 38.15 dB unshadowed against
# 37.79 shadowed (same run, same command). Only the sides of a planar emitter facing open space get a proxy
# (direct_light.open_sides: the Cornell panel, 2 mm under the ceiling, gets one proxy, not two); the rest render of
# the other models has one on both sides. Emissive meshes that are not planar (orbs, lamp shades, neon tubes) get
# sphere lights (direct_light.solid_proxy_lights): EEVEE's GI-off render gave a floor under an on-screen orb and tube
# about 60 % of Cycles' light, with the stand-ins within 2 % (tests/blender/test_solid_emitter_proxies.py); the same
# 171 artist rooms rendered with them trained a model 2.95 dB better on the artist test set in the same 25 minutes
# (docs/one_render.md). A model whose bake recorded other proxies gets those (recorded_proxy_options).
ONE_RENDER_SETTINGS = {"proxy_shadows": False, "proxy_sides": "open", "proxy_shapes": "all"}


def _recorded_proxies(meta: dict) -> dict | None:
    """The bake manifest's ``eevee.one_render`` settings from a model's checkpoint data, None unless that one render
    had emitter proxies."""
    one = (((meta or {}).get("dataset") or {}).get("settings") or {}).get("eevee", {}).get("one_render") or {}
    return one if one.get("emitter_proxies") else None


def recorded_proxy_shadows(meta: dict) -> bool | None:
    """Whether the emitter proxies of the one render a model was trained on cast shadows, from its checkpoint's
    data (the bake manifest's ``eevee.one_render``): None for a model not trained on a one render with proxies.
    Models baked before the setting was recorded had shadowed proxies."""
    one = _recorded_proxies(meta)
    return None if one is None else bool(one.get("emitter_proxy_shadows", True))


def recorded_proxy_sides(meta: dict) -> str | None:
    """Which sides of the planar emitters got a proxy in the one render a model was trained on ("open" / "both",
    ``direct_light.emitter_proxies``), from its checkpoint's data; None for a model not trained on a one render with
    proxies. Models baked before the setting was recorded had a proxy on both sides."""
    one = _recorded_proxies(meta)
    return None if one is None else str(one.get("emitter_proxy_sides", "both"))


def recorded_proxy_shapes(meta: dict) -> str | None:
    """Which emitters got a proxy in the one render a model was trained on ("planar" / "all",
    ``direct_light.emitter_proxies``), from its checkpoint's data; None for a model not trained on a one render with
    proxies. Models baked before the setting was recorded had proxies for the planar emitters only."""
    one = _recorded_proxies(meta)
    return None if one is None else str(one.get("emitter_proxy_shapes", "planar"))


def recorded_proxy_options(meta: dict) -> dict:
    """The ``render_gbuffer`` keywords that render a model's frames with the emitter proxies its bake had
    (``proxy_shadows``, ``proxy_sides``, ``proxy_shapes``); {} for a model not trained on a one render with
    proxies."""
    if _recorded_proxies(meta) is None:
        return {}
    return {"proxy_shadows": recorded_proxy_shadows(meta), "proxy_sides": recorded_proxy_sides(meta),
            "proxy_shapes": recorded_proxy_shapes(meta)}


# groups only the artist-settings render gives, whatever the samples: its Glossy Color pass (gloss: a shot's
# reflection map, model/infer/reflmap.py, corrects EEVEE's reflections where it is)
REST_ONLY_GROUPS = ("gloss",)
# (not REST_LIGHT_GROUPS: EEVEE's own diffuse light comes from the artist-settings render)
EEVEE_GROUPS: tuple[str, ...] = tuple(g for g in ch.SAMPLE_GROUPS if ch.GROUPS[g].source == "eevee"
                                      and g not in REST_LIGHT_GROUPS + REST_ONLY_GROUPS)
# what a bake renders by default: not the artist-settings render `rest` (the render path and the report render it)
BAKE_EEVEE_GROUPS: tuple[str, ...] = tuple(g for g in EEVEE_GROUPS if g != "rest")
AREA_LIGHT_SIZE = 0.01  # m: EEVEE drops area lights under ~5 mm; Cycles renders a size-0 area light black
# Lights' custom cutoff distance (m), needed with light threshold 0 (without a custom distance EEVEE then culls
# every light: measured black). Not larger: with 1e4, EEVEE lost most cast shadows (its shadow maps use this
# as their far clip) and Diffuse Direct was 0.54-1.09x Cycles'; 20-1000 m all matched (docs/bake.md).
CUTOFF_DISTANCE = 1000.0
DIFFUSE_BOUNCES = 8
# Cycles' pixel filter width (px) for the hard-light comparison. EEVEE's single sample is a point sample at the
# pixel centre (its filter size changes nothing at 1 sample: measured bit-identical at 0.01 and 1.5 px), while
# Cycles' default 1.5 px filter anti-aliases: thin bright edges (a cylinder's top seen edge-on) then differ by
# 10 % and room 13's total by 1.6 %. Point-sampled, 13 closed rooms agree within 0.5 % (docs/bake.md).
POINT_SAMPLE_FILTER_PX = 0.01


def _check_camera(scene) -> None:
    if scene.camera is None:
        raise UserError(f"scene {scene.name!r} has no camera")


def configure_gbuffer(scene, groups=None, samples: int = 1) -> None:
    """Enable the passes ``groups`` need and EEVEE's direct-only settings (persistent settings of ``scene``)."""
    groups = tuple(groups) if groups is not None else EEVEE_GROUPS
    scene.render.engine = "BLENDER_EEVEE"
    ee = scene.eevee
    ee.taa_render_samples = int(samples)
    ee.use_raytracing = False
    ee.use_fast_gi = False
    ee.use_shadows = True
    vl = scene.view_layers[0]
    for g in groups:
        flag = ch.GROUPS[g].blender_pass
        if flag:
            setattr(vl, flag, True)
    no_light_culled(scene)


def no_light_culled(scene) -> None:
    """Light threshold 0 and every lamp a custom cutoff distance of CUTOFF_DISTANCE: with threshold 0 and no
    distance, EEVEE culls every lamp (persistent settings of ``scene``)."""
    scene.eevee.light_threshold = 0.0
    for li in {o.data for o in scene.objects if o.type == "LIGHT"}:
        li.use_custom_distance = True
        li.cutoff_distance = CUTOFF_DISTANCE


@contextlib.contextmanager
def hard_lights(scene):
    """Point/spot radius 0, sun angle 0, area lights ~1 cm keeping their aspect; restored on exit."""
    saved = []
    lights: dict = {}
    for o in scene.objects:
        if o.type == "LIGHT":
            lights.setdefault(o.data, []).append(max(abs(s) for s in o.matrix_world.to_scale()))
    try:
        for li, scales in lights.items():
            if li.type in ("POINT", "SPOT"):
                saved.append((li, "shadow_soft_size", li.shadow_soft_size))
                li.shadow_soft_size = 0.0
            elif li.type == "SUN":
                saved.append((li, "angle", li.angle))
                li.angle = 0.0
            elif li.type == "AREA":
                saved.append((li, "size", li.size))
                saved.append((li, "size_y", li.size_y))
                big = max(li.size, li.size_y if li.shape in ("RECTANGLE", "ELLIPSE") else li.size, 1e-9)
                f = AREA_LIGHT_SIZE / (big * max(scales))
                li.size, li.size_y = li.size * f, li.size_y * f
        yield
    finally:
        for li, attr, v in reversed(saved):
            setattr(li, attr, v)


def _black_world(name: str):
    w = bpy.data.worlds.new(name)
    w.color = (0.0, 0.0, 0.0)
    if w.node_tree is not None:
        for n in w.node_tree.nodes:
            if n.bl_idname == "ShaderNodeBackground":
                n.inputs["Strength"].default_value = 0.0
    return w


def _camera_only_world(world, name: str):
    """A copy of ``world`` that camera rays see as before and that lights nothing: its output shader goes
    through Mix Shader(Light Path "Is Camera Ray": nothing, the world). None when ``world`` has no shader."""
    copy = world.copy()
    copy.name = name
    nt = copy.node_tree
    out = next((n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output), None) \
        if nt is not None else None
    if out is None or not out.inputs["Surface"].links:
        bpy.data.worlds.remove(copy)
        return None
    src = out.inputs["Surface"].links[0].from_socket
    path = nt.nodes.new("ShaderNodeLightPath")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(src, mix.inputs[2])  # input 1 (Fac 0) stays empty: no light
    nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    return copy


@contextlib.contextmanager
def _direct_only_world(scene, keep_sky: bool = False):
    """A world that lights nothing, and hidden light probes (EEVEE's Diffuse Direct includes world light
    otherwise). With ``keep_sky`` camera rays still see the scene's world, so that the Combined pass keeps the
    artist's background where nothing is hit; else the world is black."""
    old_world = scene.world
    tmp = None
    if keep_sky and old_world is not None:
        tmp = _camera_only_world(old_world, "ssgi.camera_only_world")
    if tmp is None:
        tmp = _black_world("ssgi.black_world")
    try:
        scene.world = tmp
        with _hidden_from_render(scene, ("LIGHT_PROBE",)):
            yield
    finally:
        scene.world = old_world
        bpy.data.worlds.remove(tmp)


@contextlib.contextmanager
def _hidden_from_render(scene, types: tuple[str, ...]):
    """The objects of ``types`` that render are hidden from the render; shown again on exit."""
    hidden = [o for o in scene.objects if o.type in types and not o.hide_render]
    try:
        for o in hidden:
            o.hide_render = True
        yield
    finally:
        for o in hidden:
            o.hide_render = False


@contextlib.contextmanager
def _point_sampled(scene):
    """Cycles' pixel filter narrowed to a point at the pixel centre; restored on exit."""
    saved = scene.cycles.filter_width
    try:
        scene.cycles.filter_width = POINT_SAMPLE_FILTER_PX
        yield
    finally:
        scene.cycles.filter_width = saved


# the codec of the multilayer EXR each render is read back through: none. The file lives only for its save and read
# (or, kept, for the compositor's stand-in, keep_render_file): at 960x540 with a one-render frame's seven passes,
# ZIP took 0.17 s to save and 0.09 s to read, no compression 0.04 s and 0.04 s (42 MB instead of 1.7;
# docs/one_render.md). A 16-bit file would be smaller still but the Depth pass is 32-bit float (only 0.01 % of its
# values survive a round to half), so the depth stays 32.
SCRATCH_EXR_CODEC = "NONE"


@contextlib.contextmanager
def _exr_output(scene):
    r = scene.render
    ims = r.image_settings
    saved = (ims.media_type, ims.file_format, ims.color_depth, ims.exr_codec, r.use_compositing, r.use_sequencer)
    try:
        ims.media_type = "MULTI_LAYER_IMAGE"
        ims.file_format = "OPEN_EXR_MULTILAYER"
        ims.color_depth = "32"
        ims.exr_codec = SCRATCH_EXR_CODEC
        r.use_compositing = False
        r.use_sequencer = False
        yield
    finally:
        ims.media_type = saved[0]
        with contextlib.suppress(TypeError):
            ims.file_format = saved[1]
        with contextlib.suppress(TypeError):
            ims.color_depth = saved[2]
        with contextlib.suppress(TypeError):
            ims.exr_codec = saved[3]
        r.use_compositing, r.use_sequencer = saved[4], saved[5]


COMPOSITE_LAYER = "Composite"


def read_multilayer(path) -> dict[str, dict[str, np.ndarray]]:
    """{pass name: {channel: HxW float32}} of a Blender multilayer (multi-part) EXR, top row first. The
    compositor's output, when the render composited, is the pass "Composite"."""
    import OpenEXR

    out: dict[str, dict[str, np.ndarray]] = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            pname = part.name() if callable(part.name) else part.name
            for name, c in part.channels.items():
                # part "ViewLayer.Diffuse Direct" with channel "R" (or one part with "ViewLayer.Diffuse Direct.R")
                full = f"{pname}.{name}" if pname and not name.startswith(f"{pname}.") else name
                layer_pass, _, comp = full.rpartition(".")
                layer, _, pass_name = layer_pass.partition(".") if "." in layer_pass else ("", "", layer_pass)
                if layer == COMPOSITE_LAYER:  # the compositor's output ("Composite.Combined"), not the view layer's
                    pass_name = COMPOSITE_LAYER
                out.setdefault(pass_name, {})[comp] = np.asarray(c.pixels, dtype=np.float32)
    return out


STALE_TEMP_S = 600.0  # a leftover temporary render file is removed when its process is gone and it is this old
_swept = False


def remove_stale_temp_files(folder=None, min_age_s: float = STALE_TEMP_S) -> list[str]:
    """Remove the ``ssgi-render-*.exr`` / ``ssgi-passes-*.exr`` scratch files (``files.scratch``) that a killed
    process left in the temporary folder: only when its process is gone and the file is older than
    ``min_age_s`` (``files.sweep``). Returns the removed names."""
    return files.sweep(folder or tempfile.gettempdir(), owned=lambda n: n.startswith(("ssgi-render-", "ssgi-passes-")),
                       min_age_s=min_age_s)


class KeptRender:
    """The read-back file of the last render made inside ``keep_render_file`` (None before one)."""
    path: str | None = None

    def discard(self) -> None:
        if self.path is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)
            self.path = None


_kept: list[KeptRender] = []


@contextlib.contextmanager
def keep_render_file():
    """Inside, the last render's read-back EXR (all its passes) is left on disk, its path in the yielded
    ``KeptRender`` (an earlier render's file is removed when the next one is made): the render path loads it as the
    compositor's stand-in for the Render Layers node instead of saving the same Render Result a second time (0.17 s
    at 960x540). ``render_gbuffer`` makes the artist-settings render last, so the file is that render's.
    The caller removes the file; on an exception it is removed here. As every read-back file, it is made only after
    its render returns, named by process (docs/hard_cases.md)."""
    kept = KeptRender()
    _kept.append(kept)
    try:
        yield kept
    except BaseException:
        kept.discard()
        raise
    finally:
        _kept.pop()


def casts_no_shadow(scene) -> bool:
    """True when nothing in an EEVEE render of ``scene`` as it stands can cast a shadow: no light object of the scene
    (hidden ones included), nor of the instances its view layer evaluates, has its shadow on, and the world's
    extracted sun casts none (``world.use_sun_shadow`` off, or a world that lights nothing, ``world_is_black``).
    A scene lit only by emissive surfaces, or a GI-off one render whose only lights are its unshadowed emitter
    proxies, is such a scene."""
    if any(o.type == "LIGHT" and o.data.use_shadow for o in scene.objects):
        return False
    with contextlib.suppress(Exception):  # (instanced lights: a light in a collection instance or from geometry nodes)
        dg = bpy.context.evaluated_depsgraph_get() if bpy.context.scene == scene else None
        if dg is not None and any(i.object.type == "LIGHT" and i.object.data.use_shadow for i in dg.object_instances):
            return False
    w = scene.world
    return not (w is not None and getattr(w, "use_sun_shadow", False) and not world_is_black(w))


# whether the last _render turned the shadows off (casts_no_shadow), whether the last render_rest left the Emission
# pass out, and whether it took the normals from the Z pass
last_render = {"shadows_skipped": False, "emission_skipped": False, "normals_from_depth": False}
# Three savings of the render path's renders, each giving the same groups (tests/blender/test_pass_merge.py):
# - _render turns EEVEE's shadows off for a render in which nothing casts one (casts_no_shadow). On Mesa EEVEE's
#   shadow pipeline costs about two thirds of a render even when no light casts a shadow (Cornell shot, 480x270,
#   16 samples: 26.3 CPU s with shadows on against 8.0 off, EEVEE GI; the GI-off one render with its unshadowed
#   proxy 29.0 against 10.7), and the image is the same to the bit. The baseline EEVEE GI render of the reports
#   keeps the scene's own setting (skip_unused_shadows=False).
# - render_rest leaves the Emission pass out where no used material of the file can write it
#   (direct_light.materials_may_emit) and gives the emission group as zeros: the pass is black to the bit there, and
#   on Mesa it cost the closed room's 960x540 GI-off render 0.9 CPU s of 22.5.
# - a one-render frame (render_gbuffer's normals=None for a one-render model's groups) takes its normals from the Z
#   pass (model/images.normals_from_depth: the geometric normals) instead of writing EEVEE's Normal pass. On Mesa the
#   Normal pass cost the closed room's 960x540 GI-off render 0.9 CPU s of 22.5 alone and about 0.5 beside the Diffuse
#   Color and Z passes, of the 4.1 that EEVEE's own GI costs there (the frame then came out
#   at 0.978x plain EEVEE GI, benchmarks/pass_cost.py); the two normals differ by a median 0.02-1.8 degrees on the
#   artist test set, and the shipped one-render model scores 22.31 dB there at 320x180 with either (world pixels get
#   a zero normal, as in the Normal pass: the clip end in _normals_from_depth; docs/one_render.md). Bakes keep the
#   pass (bake.py asks normals="pass"), and so do the frames of a model with a shot's lightmap or reflection map,
#   which read each pixel's own normal (pipeline/render.py).


@contextlib.contextmanager
def _unused_shadows_off(scene, skip: bool):
    ee = scene.eevee
    saved = ee.use_shadows
    off = bool(skip and saved and scene.render.engine == "BLENDER_EEVEE" and casts_no_shadow(scene))
    last_render["shadows_skipped"] = off
    try:
        if off:
            ee.use_shadows = False
        yield
    finally:
        ee.use_shadows = saved


def _render(scene, composite: bool = False, skip_unused_shadows: bool = True) -> dict[str, dict[str, np.ndarray]]:
    """Render ``scene`` and read every pass back; with ``composite`` the scene's compositor runs too and its
    output is the pass "Composite". Inside ``keep_render_file`` the read-back file stays. With
    ``skip_unused_shadows`` an EEVEE render in which nothing casts a shadow
    (``casts_no_shadow``) is made with EEVEE's shadows off: the same image, a third of the time on Mesa."""
    global _swept
    _check_camera(scene)
    if not _swept:
        _swept = True
        remove_stale_temp_files()
    path = None
    kept = _kept[-1] if _kept else None
    try:
        with _exr_output(scene):
            scene.render.use_compositing = composite
            vl = scene.view_layers[0]
            with _unused_shadows_off(scene, skip_unused_shadows):
                bpy.ops.render.render(scene=scene.name, layer=vl.name)
            img = bpy.data.images.get("Render Result")
            if img is None:
                raise RuntimeError("render produced no Render Result")
            # the temporary file exists only for the save and the read, not during the (long) render, so a
            # process killed while rendering leaves nothing behind (docs/hard_cases.md)
            path = str(files.scratch("ssgi-render", ".exr"))
            try:
                img.save_render(path, scene=scene)
                # A failed write (a full disk) does not raise: Blender logs "IMB_exr_write_channels: Failed to
                # write pixel data" and leaves the file empty or cut short, which the read finds.
                out = read_multilayer(path)
                if kept is not None:
                    kept.discard()
                    kept.path, path = path, None
                return out
            except RuntimeError as e:
                raise OSError(f"{path}: Blender could not save the render in the temporary folder "
                              f"{tempfile.gettempdir()} (is the disk full? Blender's log above says why): {e}") from None
    finally:
        if path is not None:
            with contextlib.suppress(OSError):
                os.unlink(path)


def _group(passes: dict, group: str) -> np.ndarray:
    name = PASS_NAMES[group]
    if name not in passes:
        raise RuntimeError(f"render has no {name!r} pass for group {group!r}; passes: {sorted(passes)}")
    p = passes[name]
    comps = ch.GROUPS[group].components
    if group == "ao" and "Y" not in p:  # AO is stored as RGB grey; keep one channel
        comps = ("R",)
    if group == "depth" and "Z" not in p:
        comps = ("V",) if "V" in p else (sorted(p)[0],)
    return np.stack([p[c] for c in comps], axis=-1).astype(np.float32)


def camera_rotation(scene) -> np.ndarray:
    """3x3 rotation of the scene camera (columns: camera X, Y, Z axes in world space)."""
    m = scene.camera.matrix_world.to_3x3().normalized()
    return np.array([[m[i][j] for j in range(3)] for i in range(3)], dtype=np.float64)


def world_to_camera_normals(n: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """World-space normals HxWx3 to camera space (+X right, +Y up, +Z towards the camera); zeros stay zero."""
    return np.einsum("hwi,ij->hwj", n.astype(np.float64), rot).astype(np.float32)


def world_is_black(world) -> bool:
    """True when ``world`` certainly lights nothing: no world, or a plain Background (colour and strength not
    driven by other nodes) of strength 0 or black colour. Then the world pass is all zeros without a render."""
    if world is None:
        return True
    nt = world.node_tree if getattr(world, "use_nodes", True) else None
    if nt is None:
        return max(world.color) <= 0.0
    out = next((n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].links:
        return True
    src = out.inputs["Surface"].links[0].from_node
    if src.bl_idname != "ShaderNodeBackground":
        return False
    col, strength = src.inputs["Color"], src.inputs["Strength"]
    if not strength.links and strength.default_value <= 0.0:
        return True
    return not col.links and max(col.default_value[:3]) <= 0.0


def render_world(scene, samples: int = 1) -> np.ndarray:
    """The ``world`` group: EEVEE's Diffuse Direct pass with the lights hidden, i.e. the world's light on each
    surface without occlusion (EEVEE lights the diffuse direct pass from the world probe, unshadowed; measured
    in docs/bake.md). HxWx3 float32, 0 where nothing is hit. A world that lights nothing (``world_is_black``)
    costs no render."""
    _check_camera(scene)
    if world_is_black(scene.world):
        r = scene.render
        h = int(r.resolution_y * r.resolution_percentage / 100)
        w = int(r.resolution_x * r.resolution_percentage / 100)
        return np.zeros((h, w, 3), np.float32)
    # the scene's settings are put back: called alone (the report renders the world pass apart), a left-over
    # direct-only configuration (ray tracing and fast GI off) made the next render of the artist's settings, the
    # rest, lose its ray-traced reflections and refraction (a black gold sphere and glass in the report's studio)
    with _settings_kept(scene):
        configure_gbuffer(scene, ("direct",), samples=samples)
        with _hidden_from_render(scene, ("LIGHT", "LIGHT_PROBE")):  # the scene's world as it is
            passes = _render(scene)
    return _group(passes, "world")[..., :3]


@contextlib.contextmanager
def _settings_kept(scene):
    """The render settings the G-buffer renders change (engine, EEVEE's, the view layer's pass flags, the
    lights' culling distance) are put back on exit, so that a later render sees the artist's own."""
    ee, vl = scene.eevee, scene.view_layers[0]
    ee_names = ("taa_render_samples", "use_raytracing", "use_fast_gi", "light_threshold", "use_shadows")
    flags = tuple(dict.fromkeys([g.blender_pass for g in ch.GROUPS.values() if g.blender_pass]
                                + list(REST_PASSES)))
    saved_ee = {n: getattr(ee, n) for n in ee_names}
    saved_vl = {f: getattr(vl, f) for f in flags}
    engine = scene.render.engine
    lights = {o.data: (o.data.use_custom_distance, o.data.cutoff_distance) for o in scene.objects if o.type == "LIGHT"}
    try:
        yield
    finally:
        scene.render.engine = engine
        for n, v in saved_ee.items():
            setattr(ee, n, v)
        for f, v in saved_vl.items():
            setattr(vl, f, v)
        for li, (use, dist) in lights.items():
            li.use_custom_distance, li.cutoff_distance = use, dist


# the passes the rest render needs (the artist's own EEVEE render)
REST_PASSES = ("use_pass_diffuse_color", "use_pass_diffuse_direct")
# G-buffer groups that do not depend on the lighting: at equal samples the artist-settings render gives them
# bit-identical to the direct-only render (measured: max |difference| 0 on a scene with a lamp, an emitter, a
# sky, metal and glass; tests/blender/test_pass_merge.py), so render_gbuffer reads them from the rest render
SHARED_GROUPS = ("albedo", "normal", "depth", "emission")
# seconds of each render of the last render_gbuffer / render_rest call: world, direct_soft, emit_direct, raster,
# rest (benchmarks/pass_cost.py prints them; a render that was not made has no entry)
last_timings: dict[str, float] = {}
# which of those renders each group of the last render_gbuffer call came from
last_sources: dict[str, str] = {}


def _tree_reads_pass(scene, name: str) -> bool:
    """Whether a link leaves the pass socket ``name`` of a Render Layers node in the scene's compositor tree (the
    render path's stand-in for that node is the render's own file, so such a pass must be in it)."""
    tree = getattr(scene, "compositing_node_group", None)
    return tree is not None and any(l.from_node.bl_idname == "CompositorNodeRLayers" and l.from_socket.name == name
                                    for l in tree.links)


def render_rest(scene, samples: int | None = None, groups=(), gi: bool | None = None, proxies: bool = False,
                proxy_shadows: bool = True, proxy_sides: str = "both", proxy_shapes: str = "planar", rest: bool = True,
                normals_from_depth: bool = False, skip_unused_shadows: bool = True, skip_empty_emission: bool = True):
    """EEVEE's own render of ``scene`` at its own settings (its samples unless ``samples``, its ray tracing and
    fast GI as set, its world, lights and probes): (rest HxWx3, Combined HxWx4), and with ``groups`` (of
    ``SHARED_GROUPS``) a third item {group: array} read from the same render. ``rest`` = Combined - Diffuse
    Color x Diffuse Light, all that EEVEE renders besides diffuse light: emission, the world seen directly,
    glossy and metal reflections, transmission, volumes. EEVEE's Diffuse Direct pass holds all of its diffuse
    light (with ray tracing on, the traced indirect too): in a closed diffuse room rest measured -0.001 mean
    (|rest| 0.0017 against a 0.30 image), with ray tracing off and on (docs/bake.md). No lamp is culled: light
    threshold 0 and every lamp's cutoff distance set, as in the G-buffer (``configure_gbuffer``), so that the
    highlights and reflections the rest holds are lit by the same lamps as the predicted diffuse light. At the
    scene's own threshold (Blender's default 0.01) the artist test set's studio rendered 16 % darker (Combined
    mean 0.312 against 0.374; 95 % of the pixels differ by more than 0.01) and its gold sphere reflected a dim
    floor (docs/channels.md). ``groups`` may also hold ``eevee_local`` (REST_LIGHT_GROUPS: the Diffuse Direct
    pass, EEVEE's own diffuse light) and ``eevee_combined`` (the Combined image). ``gi`` True / False switches ray
    tracing and fast GI on / off whatever the scene says (their other settings stay the artist's): the one render is
    made with both off; None keeps the scene's. With ``proxies`` an area light stands in for each planar emitter
    during the render (``direct_light.emitter_proxies``; the render path's and the bakes' rest), so that EEVEE's
    reflections and transmission see the light the emitters cast (without, EEVEE lights nothing from an emissive mesh
    off screen, and its reflections of the walls a panel lights were dark); without, the render is EEVEE's own.
    ``proxy_shadows`` False: the proxies cast no shadow; ``proxy_sides`` "open": a proxy only for the sides of an
    emitter that face open space (``ONE_RENDER_SETTINGS``); ``proxy_shapes`` "all": the non-planar emitters get
    sphere lights too (``direct_light.emitter_proxies``). ``rest`` False: the render writes only
    the passes of ``groups`` (no Diffuse Color or Diffuse Direct for a rest) and the first item is None; with
    ``groups`` holding ``eevee_combined`` (that render's Combined RGB) and not ``eevee_local``, the render of a
    ref_combined model's frame, which needs no Diffuse Direct pass. ``normals_from_depth`` with ``groups`` holding
    ``normal`` and ``depth``: no Normal pass is written, the normals are the surfaces' geometric ones from the Z pass
    (``last_render``). With ``skip_empty_emission``, where no used material can emit no Emission pass is written and
    ``emission`` is zeros; ``skip_unused_shadows``: as ``_render``'s. The settings it changes are put back."""
    from . import direct_light

    _check_camera(scene)
    for g in groups:
        if g not in SHARED_GROUPS + REST_LIGHT_GROUPS + REST_ONLY_GROUPS + EXTRA_GROUPS:
            raise ValueError(f"group {g!r} does not come from the artist-settings render; those are: "
                             f"{SHARED_GROUPS + REST_LIGHT_GROUPS + REST_ONLY_GROUPS + EXTRA_GROUPS}")
    with _settings_kept(scene), (direct_light.emitter_proxies(scene, proxy_shadows, proxy_sides, proxy_shapes) if proxies
                                           else contextlib.nullcontext()):
        scene.render.engine = "BLENDER_EEVEE"
        if samples:
            scene.eevee.taa_render_samples = int(samples)
        if gi is not None:
            scene.eevee.use_raytracing = scene.eevee.use_fast_gi = bool(gi)
        no_light_culled(scene)
        vl = scene.view_layers[0]
        # the Emission pass of a file where nothing can emit is black: not written, zeros instead (exact)
        # (the view layer's flag, which setup_scene turns on for the model's passes, is off for the render and put
        # back after it; kept on where the artist's compositor tree reads the pass from a Render Layers node)
        black = ("emission",) if ("emission" in groups and skip_empty_emission
                                  and not _tree_reads_pass(scene, PASS_NAMES["emission"])
                                  and not direct_light.materials_may_emit()) else ()
        # the normals from the Z pass instead of a Normal pass
        derived = ("normal",) if (normals_from_depth and "normal" in groups and "depth" in groups
                                  and not _tree_reads_pass(scene, PASS_NAMES["normal"])) else ()
        last_render["emission_skipped"], last_render["normals_from_depth"] = bool(black), bool(derived)
        for f in (REST_PASSES if rest else ()) + tuple(ch.GROUPS[g].blender_pass for g in groups
                                                        if g not in black + derived):
            if f:  # (eevee_combined: the Combined pass, always written)
                setattr(vl, f, True)
        for g in black + derived:
            setattr(vl, ch.GROUPS[g].blender_pass, False)
        t0 = time.perf_counter()
        passes = _render(scene, skip_unused_shadows=skip_unused_shadows)
        last_timings["rest"] = time.perf_counter() - t0
    comb = passes["Combined"]
    combined = np.stack([comb[c] for c in "RGBA"], axis=-1).astype(np.float32)
    light = _rgb(passes, "Diffuse Direct") if rest or any(g in DIFFUSE_LIGHT_GROUPS for g in groups) else None
    made = (combined[..., :3] - _rgb(passes, "Diffuse Color") * light).astype(np.float32) if rest else None
    if not groups:
        return made, combined
    return made, combined, {g: np.ascontiguousarray(combined[..., :3]) if g == "eevee_combined" else
                            light if g in REST_LIGHT_GROUPS else
                            np.zeros(combined.shape[:2] + (3,), np.float32) if g in black else
                            _normals_from_depth(scene, _group(passes, "depth")) if g in derived else _group(passes, g)
                            for g in groups}


def _normals_from_depth(scene, depth: np.ndarray) -> np.ndarray:
    """World-space normals (as EEVEE's Normal pass gives them) of the surfaces the Z pass ``depth`` shows
    (model/images.normals_from_depth, in camera space, turned by the camera's rotation); zero where it shows the
    world (the depth at the camera's clip end)."""
    from ...model.images import normals_from_depth
    from .views import camera_matrices
    h, w = depth.shape[:2]
    n = normals_from_depth(depth, camera_matrices(scene, size=(w, h))["P"], clip_end=scene.camera.data.clip_end)
    return np.einsum("hwj,ij->hwi", n.astype(np.float64), camera_rotation(scene)).astype(np.float32)


# The world group is the sky's unoccluded light on each surface, smooth but for the geometry's edges: it is
# rendered at 1 sample whatever the G-buffer's samples (bakes render it so), not at the artist's 16-64.
WORLD_SAMPLES = 1
# groups rendered by a render of their own (direct_light.py: soft direct light; the emitters' direct light, a
# Cycles render), in this order
# sky: the world's L1 light at the normal (sky.py: a small Cycles image of the world alone, no render of the scene)
OWN_RENDER_GROUPS = ("world", "direct_soft", "emit_direct", "surround", "sky")  # surround: ray casts, no render
# every input group a render of the scene gives (emit_direct is Cycles', surround ray casts, the rest EEVEE's), and
# the extras the render path asks for: "vector" (EEVEE's motion vectors, from the direct-only raster render; the
# temporal mode)
EXTRA_GROUPS: tuple[str, ...] = ("vector",)
INPUT_RENDER_GROUPS: tuple[str, ...] = (EEVEE_GROUPS + ("emit_direct", "surround", "sky") + EXTRA_GROUPS + REST_LIGHT_GROUPS
                                        + REST_ONLY_GROUPS)


def render_gbuffer(scene, groups=None, samples: int = 1, keep_sky: bool = True,
                   rest_samples: int | None = None, merge: bool = True,
                   raster_samples: int | None = None, proxies: bool = True,
                   proxy_shadows: bool | None = None, proxy_sides: str | None = None,
                   proxy_shapes: str | None = None, normals: str | None = None, skip_unused_shadows: bool = True,
                   skip_empty_emission: bool = True) -> dict[str, np.ndarray]:
    """Render EEVEE's direct-only G-buffer: ``{group: HxWxC float32}``, top row first, normals in camera space.
    The world lights nothing; with ``keep_sky`` the Combined pass (``eevee``) still shows it where nothing is
    hit (tests/blender/test_bake.py checks that Diffuse Direct is the same either way). ``world``,
    ``direct_soft`` and ``emit_direct`` (a Cycles render, only in a scene with emitters) take a render each;
    ``rest`` is the artist's own render (``render_rest`` at ``rest_samples``, default the scene's), rendered
    last, so that the Render Result left behind is that render (render.py saves it for the artist's compositor
    tree). With ``merge`` and ``rest`` at the G-buffer's samples, the ``SHARED_GROUPS`` come from the rest
    render (bit-identical; docs/one_render.md), and the direct-only render is made only for what is left
    (``direct``, ``eevee``, ``ao``), at ``raster_samples`` (default ``samples``; 1 changes ``direct`` on edges
    and was measured, not made the default: docs/one_render.md). ``last_timings`` holds each render's seconds,
    ``last_sources`` which render each group came from. ``eevee_combined`` and ``eevee_local`` (a one-render
    model's one render, docs/one_render.md) come from the artist-settings render made with ray tracing and fast GI
    off and the emitter proxies on; asked for either, the SHARED_GROUPS (and the motion vectors) come from that
    render whatever the samples, so that a one-render model's every input is of that one render. ``proxies``: the
    rest render stands area lights in for planar emitters (``render_rest``); ``proxy_shadows``: whether they cast
    shadows (None: ``ONE_RENDER_SETTINGS``' for a one-render model, else True; a model's own is
    ``recorded_proxy_shadows``); ``proxy_sides``: which sides of an emitter get one (None: ``ONE_RENDER_SETTINGS``'
    for a one-render model, else "both"; a model's own is ``recorded_proxy_sides``); ``proxy_shapes``: which emitters
    get one, "planar" or "all" (None: ``ONE_RENDER_SETTINGS``' for a one-render model, else "planar"; a model's own is
    ``recorded_proxy_shapes``). ``normals``: "pass" (EEVEE's
    Normal pass) or "depth" (the geometric normals from the Z pass, where the normal and the depth come from the
    artist-settings render: ``render_rest(normals_from_depth=True)``); None: "depth" for a one-render model's groups,
    else "pass". ``skip_unused_shadows``, ``skip_empty_emission``: the savings of ``_render`` and ``render_rest``
    (the same groups either way). The scene's render settings are put back."""
    from . import direct_light

    groups = tuple(groups) if groups is not None else EEVEE_GROUPS
    for g in groups:
        if g not in INPUT_RENDER_GROUPS:
            raise ValueError(f"group {g!r} is not rendered from the scene; those are: {INPUT_RENDER_GROUPS}")
    asked = groups
    if "sky" in groups and "normal" not in groups:  # (the sky group is the world's light at the normal)
        groups += ("normal",)
    _check_camera(scene)
    last_timings.clear()
    last_sources.clear()
    last_render["emission_skipped"] = last_render["normals_from_depth"] = False
    rest_at = int(rest_samples) if rest_samples else int(scene.eevee.taa_render_samples)
    one = any(g in REST_LIGHT_GROUPS for g in groups)  # a one-render model: every group from its one render
    gi, proxied = (False, True) if one else (None, proxies)
    shadowed = bool(proxy_shadows) if proxy_shadows is not None else (ONE_RENDER_SETTINGS["proxy_shadows"] if one
                                                                        else True)
    sides = proxy_sides or (ONE_RENDER_SETTINGS["proxy_sides"] if one else "both")
    shapes = proxy_shapes or (ONE_RENDER_SETTINGS["proxy_shapes"] if one else "planar")
    if shapes not in ("planar", "all"):
        raise ValueError(f"proxy_shapes {shapes!r}: 'planar' or 'all'")
    normals = normals or ("depth" if one else "pass")
    if normals not in ("pass", "depth"):
        raise ValueError(f"normals {normals!r}: 'pass' or 'depth'")
    if sides not in ("open", "both"):
        raise ValueError(f"proxy_sides {sides!r}: 'open' or 'both'")
    with_rest = "rest" in groups or one or any(g in REST_ONLY_GROUPS for g in groups)
    # (a one-render model's motion vectors, for the temporal mode, come from that render too: they do not depend
    # on the lighting)
    shared = tuple(g for g in groups if g in SHARED_GROUPS + (EXTRA_GROUPS if one else ())) \
        if merge and with_rest and (rest_at == int(samples) or one) else ()
    rest_groups = shared + tuple(g for g in groups if g in REST_LIGHT_GROUPS + REST_ONLY_GROUPS)
    raster = tuple(g for g in groups if g not in OWN_RENDER_GROUPS + ("rest",) + rest_groups)
    out = {}

    def timed(key, fn, *a, **kw):
        t0 = time.perf_counter()
        r = fn(*a, **kw)
        last_timings[key] = time.perf_counter() - t0
        return r

    with _settings_kept(scene):
        if "world" in groups:  # smooth unoccluded light: 1 sample, as every bake renders it (WORLD_SAMPLES)
            out["world"] = timed("world", render_world, scene, samples=WORLD_SAMPLES)
        if "direct_soft" in groups:
            out["direct_soft"] = timed("direct_soft", direct_light.render_soft_direct, scene)
        if "emit_direct" in groups:
            out["emit_direct"] = timed("emit_direct", direct_light.emitter_direct, scene)
        if "surround" in groups:
            from .surround import render_surround
            out["surround"] = timed("surround", render_surround, scene)
        if raster:
            configure_gbuffer(scene, raster, samples=raster_samples or samples)
            with _direct_only_world(scene, keep_sky=keep_sky), hard_lights(scene):
                passes = timed("raster", _render, scene, skip_unused_shadows=skip_unused_shadows)
            out.update({g: _group(passes, g) for g in raster})
    # (a ref_combined model's frame: its one render without the Diffuse Direct pass a rest would need)
    need_rest = not one or "rest" in groups or any(g in DIFFUSE_LIGHT_GROUPS for g in groups)
    if with_rest:
        made = render_rest(scene, rest_samples, groups=rest_groups, gi=gi, proxies=proxied, proxy_shadows=shadowed,
                           proxy_sides=sides, proxy_shapes=shapes, rest=need_rest, normals_from_depth=normals == "depth",
                           skip_unused_shadows=skip_unused_shadows, skip_empty_emission=skip_empty_emission)
        out["beauty"] = made[1]
        if made[0] is not None:
            out["rest"] = made[0]
        if rest_groups:
            out.update(made[2])
    last_sources.update({g: "rest" if g in rest_groups + ("rest",) else "raster" if g in raster else g for g in asked})
    if "normal" in out:
        out["normal"] = world_to_camera_normals(out["normal"], camera_rotation(scene))
    if "sky" in groups:
        from .sky import render_sky
        out["sky"] = timed("sky", render_sky, scene, out["normal"])
    return {g: out[g] for g in asked if g in out} | ({"beauty": out["beauty"]} if "beauty" in out else {})


def configure_cycles(scene, samples: int, seed: int = 0, denoise: bool = False, threads: int = 0) -> None:
    c = scene.cycles
    scene.render.engine = "CYCLES"
    c.device = "CPU"
    c.samples = int(samples)
    c.use_adaptive_sampling = False
    c.seed = int(seed)
    c.use_animated_seed = False
    c.diffuse_bounces = max(DIFFUSE_BOUNCES, c.diffuse_bounces)
    c.max_bounces = max(c.max_bounces, c.diffuse_bounces)
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.use_denoising = bool(denoise)
    if denoise:
        c.denoiser = "OPENIMAGEDENOISE"
        c.denoising_input_passes = "RGB_ALBEDO_NORMAL"
    scene.render.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        scene.render.threads = threads


def _rgb(passes: dict, name: str) -> np.ndarray:
    if name not in passes:
        raise RuntimeError(f"render has no {name!r} pass; passes: {sorted(passes)}")
    return np.stack([passes[name][c] for c in "RGB"], axis=-1).astype(np.float32)


def _mix_node(tree, blend: str):
    n = tree.nodes.new("ShaderNodeMix")
    n.data_type, n.blend_type = "RGBA", blend
    n.inputs[0].default_value = 1.0
    a, b = [s for s in n.inputs if s.enabled and s.type == "RGBA"]
    out = next(o for o in n.outputs if o.enabled)
    return a, b, out


@contextlib.contextmanager
def _denoised_diffuse_compositor(scene):
    """A compositor that outputs the diffuse part of a Cycles render, Diffuse Color x (Diffuse Direct + Diffuse
    Indirect), denoised by OIDN with the Diffuse Color as albedo and the Normal pass as guides (Cycles itself
    denoises only Combined). The scene's compositor is put back on exit. Measured on room 5 at 160x90 against
    1024 spp: 37.3 dB at 16 spp (raw 25.0 dB), the denoised Combined 38.4 dB (docs/bake.md)."""
    old_tree, old_use = scene.compositing_node_group, scene.render.use_compositing
    tree = bpy.data.node_groups.new("ssgi.diffuse_reference", "CompositorNodeTree")
    try:
        tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
        rl = tree.nodes.new("CompositorNodeRLayers")
        rl.scene = scene
        rl.layer = scene.view_layers[0].name
        a, b, added = _mix_node(tree, "ADD")
        tree.links.new(rl.outputs["Diffuse Direct"], a)
        tree.links.new(rl.outputs["Diffuse Indirect"], b)
        a, b, product = _mix_node(tree, "MULTIPLY")
        tree.links.new(added, a)
        tree.links.new(rl.outputs["Diffuse Color"], b)
        dn = tree.nodes.new("CompositorNodeDenoise")
        tree.links.new(product, dn.inputs["Image"])
        tree.links.new(rl.outputs["Normal"], dn.inputs["Normal"])
        tree.links.new(rl.outputs["Diffuse Color"], dn.inputs["Albedo"])
        out = tree.nodes.new("NodeGroupOutput")
        tree.links.new(dn.outputs[0], out.inputs[0])
        scene.compositing_node_group = tree
        yield
    finally:
        scene.compositing_node_group = old_tree
        scene.render.use_compositing = old_use
        bpy.data.node_groups.remove(tree)


def render_cycles(scene, samples: int, seed: int = 0, denoise: bool = False, hard: bool = False,
                  groups=("ref",), threads: int = 0) -> dict[str, np.ndarray]:
    """Render Cycles. ``groups`` may hold "ref" (Combined RGB), "direct" (Diffuse Direct) and "ref_diffuse"
    (the diffuse part, Diffuse Color x (Diffuse Direct + Diffuse Indirect): denoised like the Combined image
    with ``denoise``, by the compositor's OIDN node). With ``hard``, the lights are shrunk as for EEVEE, the
    world is black and the pixels are point samples at their centres, as EEVEE's 1-sample G-buffer is (to
    compare with EEVEE's Diffuse Direct)."""
    _check_camera(scene)
    configure_cycles(scene, samples, seed, denoise, threads)
    vl = scene.view_layers[0]
    if "direct" in groups:
        vl.use_pass_diffuse_direct = True
    diffuse = "ref_diffuse" in groups
    if diffuse:
        vl.use_pass_diffuse_color = vl.use_pass_diffuse_direct = vl.use_pass_diffuse_indirect = True
        vl.use_pass_normal = True
    ctx = contextlib.ExitStack()
    with ctx:
        if hard:
            ctx.enter_context(_direct_only_world(scene))
            ctx.enter_context(hard_lights(scene))
            ctx.enter_context(_point_sampled(scene))
        if diffuse and denoise:
            ctx.enter_context(_denoised_diffuse_compositor(scene))
        passes = _render(scene, composite=diffuse and denoise)
    out = {}
    for g in groups:
        if g == "ref_diffuse":
            out[g] = (_rgb(passes, COMPOSITE_LAYER) if denoise else
                      _rgb(passes, "Diffuse Color") * (_rgb(passes, "Diffuse Direct") + _rgb(passes, "Diffuse Indirect")))
        else:
            out[g] = _group(passes, g)[..., :3]
    return out


def set_resolution(scene, width: int, height: int) -> None:
    scene.render.resolution_x, scene.render.resolution_y = int(width), int(height)
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
