"""The channel spec: the single contract between the baker that writes samples and the network that reads them.

A dataset sample is one single-part OpenEXR file whose channels are named ``<group>.<component>``, for
example ``albedo.R`` or ``depth.Z``. The groups a sample may hold are listed in ``GROUPS``. Nothing else in
the project hard-codes channel names or indices: ask this module.

An *input spec* is an ordered tuple of input group names (stored groups, or the derived group ``lit``). It is
written as a comma-separated string, e.g. ``"albedo,normal,depth,direct,lit"``; ``parse_spec`` checks it.
"""
from __future__ import annotations

from dataclasses import dataclass

from .errors import UserError

FORMAT_VERSION = 1


@dataclass(frozen=True)
class Group:
    name: str
    components: tuple[str, ...]
    kind: str  # "color" [0,1] | "normal" unit vector | "depth" metres | "light" HDR >= 0 | "unit" [0,1] | "alpha"
    # | "motion" pixels (the Vector pass: an extra of the render path, never stored in samples nor an input)
    source: str  # which renderer writes it, for the docs and the node
    blender_pass: str | None  # Blender view-layer pass that produces it (None: derived or Combined)
    units: str
    doc: str
    render_pass: str | None = None  # the Render Layers socket / EXR pass the renderer reads it from
    preview: str = "light"  # its tile in the dataset preview: light | color | normal | depth | grey
    drop_rank: int | None = None  # the fit's input ablation tries groups in this order (None: never dropped)

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(f"{self.name}.{c}" for c in self.components)

    @property
    def size(self) -> int:
        return len(self.components)


# the surround group's 12 components: per camera-space direction bin, open share then nearness
SURROUND_BINS: tuple[str, ...] = ("R", "L", "U", "D", "F", "B")
SURROUND_COMPONENTS: tuple[str, ...] = tuple(b + k for b in SURROUND_BINS for k in ("O", "N"))

GROUPS: dict[str, Group] = {g.name: g for g in (
    Group("albedo", ("R", "G", "B"), "color", "eevee", "use_pass_diffuse_color", "reflectance",
          "EEVEE Diffuse Color pass.", render_pass="Diffuse Color", preview="color", drop_rank=7),
    Group("normal", ("X", "Y", "Z"), "normal", "eevee", "use_pass_normal", "unit vector",
          "Shading normal in CAMERA space (+X right, +Y up, +Z towards the camera); (0,0,0) where nothing is hit.",
          render_pass="Normal", preview="normal", drop_rank=4),
    Group("depth", ("Z",), "depth", "eevee", "use_pass_z", "scene units",
          "EEVEE Depth pass: distance along the view axis; the camera's clip end (or larger) where nothing is hit.",
          render_pass="Depth", preview="depth", drop_rank=3),
    Group("direct", ("R", "G", "B"), "light", "eevee", "use_pass_diffuse_direct", "linear radiance (HDR)",
          "EEVEE Diffuse Direct light with hard shadows (tiny lights, no GI, black world).", render_pass="Diffuse Direct",
          drop_rank=6),
    Group("world", ("R", "G", "B"), "light", "eevee", "use_pass_diffuse_direct", "linear radiance (HDR)",
          "World light alone, unoccluded: EEVEE's Diffuse Direct pass of a render with the lights hidden and the "
          "world lighting (no shadows from the world, no bounces). 0 where nothing is hit and in a black world. "
          "Tells the network how much light the sky can bring, which no other input shows.",
          render_pass="Diffuse Direct", drop_rank=0),  # of a second render; first to drop: it costs that render
    Group("ao", ("Y",), "unit", "eevee", "use_pass_ambient_occlusion", "[0,1]",
          "EEVEE Ambient Occlusion pass (grey, one channel kept).", render_pass="Ambient Occlusion", preview="grey",
          drop_rank=2),
    Group("emission", ("R", "G", "B"), "light", "eevee", "use_pass_emit", "linear radiance (HDR)",
          "EEVEE Emission pass of the G-buffer render: the light emissive surfaces give off towards the camera. "
          "EEVEE's direct light ignores emissive meshes (they light nothing without ray tracing), so this is the "
          "only input that shows an emission-lit scene's light sources.", render_pass="Emission", drop_rank=1),
    Group("direct_soft", ("R", "G", "B"), "light", "eevee", "use_pass_diffuse_direct", "linear radiance (HDR)",
          "EEVEE Diffuse Direct light with the lights at their real size (soft shadows), of a render of its own "
          "with the G-buffer's direct-only world and settings: 4 samples, 4 shadow rays of 12 steps, point-sampled "
          "pixels (ssgi_addon/blender/direct_light.py render_soft_direct; +5.5 dB over the hard input against "
          "Cycles' soft direct light on 6 rooms, docs/direct_light.md).",
          render_pass="Diffuse Direct", drop_rank=0),
    Group("emit_direct", ("R", "G", "B"), "light", "cycles", None, "linear radiance (HDR)",
          "The diffuse direct light that emissive surfaces cast (which EEVEE's direct light ignores): Cycles' "
          "Diffuse Direct pass with the lamp objects hidden, the world black and no bounces, 4 spp, OIDN-denoised "
          "(ssgi_addon/blender/direct_light.py render_emitter_direct; zeros without a render in a scene with no "
          "emitter). Measured 34.8-42.2 dB against converged Cycles on panel-lit rooms (docs/direct_light.md).",
          render_pass="Diffuse Direct", drop_rank=0),
    Group("surround", SURROUND_COMPONENTS, "unit", "bpy", None, "[0,1]",
          "What lies around the camera, on screen or not: rays cast from the camera in 256 fixed directions (camera "
          "space), binned by the nearest camera axis (R(ight) L(eft) U(p) D(own) F(ront, the view direction) "
          "B(ack)); per bin the share of rays that hit nothing within the clip end (...O, open) and the mean of "
          "m / (d + m) over the rays (...N, near; 0 for a miss), d the hit distance and m the median of all hit "
          "distances (scale free, as depth). Constant over the image. Tells a closed room (walls all round, "
          "behind the camera too) from an open stage or a sky (ssgi_addon/blender/surround.py).",
          render_pass=None, preview="grey", drop_rank=1),
    Group("sky", ("R", "G", "B"), "light", "cycles", None, "linear radiance (HDR)",
          "The world's light on each surface, unoccluded, without a render of the scene: the world's first-order "
          "spherical harmonics (from a 64x32 equirectangular Cycles image of the world alone) evaluated at the "
          "normal, as EEVEE lights a diffuse surface from the world (model/sky.py; within 2-5 % of the world group "
          "on the artist test set). 0 where nothing is hit and in a black world. Tells a GI-off one-render model how "
          "much of its image is the sky's unoccluded light (docs/one_render.md).",
          render_pass=None, drop_rank=1),
    Group("rest", ("R", "G", "B"), "light", "eevee", None, "linear radiance (HDR)",
          "What EEVEE renders well itself: EEVEE's Combined image of the scene at its own settings minus EEVEE's "
          "diffuse part (Diffuse Color x Diffuse Light): emission, the world seen directly, glossy and metal "
          "reflections, transmission (glass), volumes. Not a network input: the SSGI image of a model that "
          "predicts the diffuse part (target ref_diffuse) is prediction + rest (model/infer/compose.py).",
          render_pass=None),
    Group("gloss", ("R", "G", "B"), "color", "eevee", "use_pass_glossy_color", "reflectance",
          "EEVEE's Glossy Color pass of the artist-settings render (the render that gives rest): how strongly each "
          "surface reflects, per channel (a metal's colour, a dielectric's Fresnel-weighted specular). A shot's "
          "reflection map (model/infer/reflmap.py) corrects EEVEE's reflections by gloss x its field; the input of "
          "head residual_combined_gloss (metal takes the light a GI-off render lacks).",
          render_pass="Glossy Color", preview="color"),
    Group("eevee_local", ("R", "G", "B"), "light", "eevee", "use_pass_diffuse_direct", "linear radiance (HDR)",
          "EEVEE's own diffuse light with ray tracing and fast GI OFF, at the artist's samples, with an area light "
          "standing in for each planar emitter (the render path's emitter proxies; casting no shadow unless "
          "the model's bake recorded otherwise): the lamps at their real size "
          "with soft shadows and the world's light from the probes, no indirect light. Stored by one-render bakes "
          "beside eevee_combined (the same render, docs/one_render.md) and composed with it into their rest; not a "
          "network input.",
          render_pass="Diffuse Direct", drop_rank=None),
    Group("eevee_combined", ("R", "G", "B"), "light", "eevee", None, "linear radiance (HDR)",
          "EEVEE's Combined image of the same GI-off one render as eevee_local (ray tracing and fast GI off, the "
          "emitter proxies on, the artist's samples): the lamps' light with soft shadows on every component, "
          "specular and emission included, no indirect light. The input of GI-off one-render models that do without "
          "the Diffuse Direct pass (head residual_combined, target ref_combined, docs/one_render.md): "
          "their image is this render + albedo x the light it lacks.",
          render_pass="Combined", drop_rank=None),
    Group("vector", ("X", "Y", "Z", "W"), "motion", "eevee", "use_pass_vector", "pixels",
          "EEVEE Vector pass (motion vectors): X, Y = the pixel's position in the PREVIOUS frame minus its position "
          "now, Z, W = its position now minus its position in the NEXT frame, in pixels, x right, y UP (measured: "
          "model/infer/temporal.py). Not a network input: the temporal mode reprojects earlier frames with it.",
          render_pass="Vector", preview="grey"),
    Group("eevee", ("R", "G", "B", "A"), "light", "eevee", None, "linear radiance (HDR)",
          "EEVEE's own direct-lit Combined image with the same hard lights; the 'local illumination' baseline.",
          render_pass="Combined"),
    Group("ref", ("R", "G", "B"), "light", "cycles", None, "linear radiance (HDR)",
          "Cycles path-traced reference with the lights' real radius: the whole image; the training target of "
          "models with target 'ref' (the first models, which learned the whole image).", render_pass="Combined"),
    Group("ref_diffuse", ("R", "G", "B"), "light", "cycles", None, "linear radiance (HDR)",
          "The diffuse part of the Cycles reference: Diffuse Color x (Diffuse Direct + Diffuse Indirect), denoised "
          "with OIDN (albedo and normal guides) when the bake denoises. The target of models that predict only "
          "what EEVEE cannot render (target 'ref_diffuse'): glossy, glass and emission stay out of it.",
          render_pass=None),
)}

# Derived input groups: computed from stored groups, never stored or rendered themselves.
# (their drop ranks among the stored groups' ``Group.drop_rank``: DERIVED_DROP_RANK)
DERIVED: dict[str, tuple[tuple[str, ...], int, str]] = {
    "lit": (("albedo", "direct"), 3, "albedo * direct: the direct-lit diffuse image (linear radiance, HDR)."),
    "scene": (("albedo", "direct", "normal"), 7,
              "Whole-image statistics broadcast to every pixel: mean log1p(albedo*direct) RGB and mean albedo RGB "
              "over the geometry pixels, and the geometry fraction. Gives a small network the room's overall light "
              "level, which sets the indirect light everywhere (a per-image linear fit beat the global one by "
              "2.4 dB, docs/model.md). Computed on the full image, so crops and tiles see the same values."),
    "scene_comb": (("albedo", "eevee_combined", "normal"), 7,
                   "As 'scene', from EEVEE's GI-off Combined image of a combined one-render model: mean "
                   "log1p(eevee_combined) RGB and mean albedo RGB over the geometry pixels, and the geometry "
                   "fraction. The light level of the whole frame, lamps, sky and emitter proxies, for a general "
                   "(not per-shot) combined model."),
    "glow": (("emission",), 4,
             "Whole-image statistics of the emission pass broadcast to every pixel: mean log1p(emission) RGB over "
             "all pixels and the share of emissive pixels (emission > 0.01). Tells the network how much light the "
             "emitters on screen give off, wherever they are in the image."),
}

DERIVED_DROP_RANK: dict[str, int] = {"scene": 1, "lit": 5, "glow": 1, "scene_comb": 1}
# derived groups that are whole-image statistics (normalised already), not light
STAT_GROUPS: tuple[str, ...] = ("scene", "glow", "scene_comb")

# Groups every sample holds. "eevee" and "ref" are not network inputs.
SAMPLE_GROUPS: tuple[str, ...] = ("albedo", "normal", "depth", "direct", "ao", "world", "emission", "direct_soft",
                                  "emit_direct", "surround", "sky", "rest", "gloss", "eevee_local",
                                  "eevee_combined", "eevee", "ref_diffuse", "ref")
# Groups added after the first datasets were baked: a sample without them is still whole (an older bake); the
# dataset's manifest (its channel_spec) says which groups its samples hold.
OPTIONAL_GROUPS: tuple[str, ...] = ("world", "emission", "direct_soft", "emit_direct", "surround", "sky", "rest",
                                    "gloss", "eevee_local", "eevee_combined", "ref_diffuse")
INPUT_GROUPS: tuple[str, ...] = ("albedo", "normal", "depth", "direct", "ao", "world", "emission", "direct_soft",
                                 "emit_direct", "surround", "sky", "eevee_combined",
                                 "gloss", "lit",
                                 "scene", "glow", "scene_comb")
# What a model learns (its checkpoint's "target"): "ref", the whole Cycles image (the first models), or
# "ref_diffuse", the diffuse part only, which the render path adds to EEVEE's own other components ("rest").
# A third, "ref_combined" (GI-off one-render models without the Diffuse Direct pass): the whole Cycles
# image, learned as EEVEE's GI-off Combined image (group eevee_combined) + albedo x the light it lacks (head
# residual_combined); the model's prediction is that addition (signed: the network may also take light away where
# EEVEE's is brighter), and the SSGI image is prediction + eevee_combined. No rest, no Diffuse Direct pass.
TARGETS: tuple[str, ...] = ("ref", "ref_diffuse", "ref_combined")
TARGET_GROUP = "ref"  # the image every method is scored against, and the target of a checkpoint that names none
DIFFUSE_TARGET = "ref_diffuse"
COMBINED_TARGET = "ref_combined"
# the albedo a ref_combined model's base light C / albedo is divided by at least (network.Head "residual_combined");
# below it the shot's reflection map takes over from the network (reflmap.ReflectionMap.apply_combined)
COMBINED_ALBEDO_FLOOR = 0.05
# the stored groups each target is read from (the others are stored groups themselves)
TARGET_SOURCES: dict[str, tuple[str, ...]] = {COMBINED_TARGET: ("ref", "eevee_combined")}
# targets SSGI no longer learns: {target: what its models learned}
GONE_TARGETS: dict[str, str] = {"ref_minus_rest": "Cycles' image minus EEVEE's rest"}
REFIT_GONE_TARGET = "fit it again with `cli.py fit`"


def check_target(target: str) -> str:
    if target in GONE_TARGETS:
        raise UserError(f"target {target!r} ({GONE_TARGETS[target]}) is one SSGI no longer learns; {REFIT_GONE_TARGET}")
    if target not in TARGETS:
        raise UserError(f"unknown target {target!r}; known: {', '.join(TARGETS)}")
    return target


def refuse_gone_target(arch, where) -> None:
    """UserError when a model's ``arch`` (from ``where``) names a target SSGI no longer learns (``GONE_TARGETS``)."""
    target = (arch or {}).get("target") if isinstance(arch, dict) else None
    if target in GONE_TARGETS:
        raise UserError(f"{where}: was fitted to learn {GONE_TARGETS[target]} (target {target!r}), which SSGI no "
                        f"longer does; {REFIT_GONE_TARGET}")


def target_groups(target: str) -> tuple[str, ...]:
    """The stored groups a sample's ``target`` is built from."""
    return TARGET_SOURCES.get(check_target(target), (target,))


def adds_rest(target: str) -> bool:
    """Whether the SSGI image of a model of ``target`` is its prediction + EEVEE's rest (model/infer/compose.py):
    ref_diffuse models; a ref model's prediction is the whole image."""
    return check_target(target) == DIFFUSE_TARGET


def base_group(target: str) -> str | None:
    """The EEVEE group a model's prediction is added to for the SSGI image (model/infer/compose.py): ``rest`` for
    ref_diffuse models, ``eevee_combined`` for ref_combined models, None for ref models (their prediction is the
    whole image)."""
    t = check_target(target)
    return "rest" if t == DIFFUSE_TARGET else "eevee_combined" if t == COMBINED_TARGET else None


def signed_part(target: str) -> bool:
    """Whether a model's predicted part may be negative (a ref_combined model's: the light it takes from EEVEE's
    image), so that the working-resolution upsample, the lightmap and the temporal blend keep it signed."""
    return check_target(target) == COMBINED_TARGET


def adds_part(target: str) -> bool:
    """Whether a model of ``target`` predicts a part of the image that is added to an EEVEE group (``base_group``):
    albedo x light, brought back from a working resolution as light (model/infer/workres.py)."""
    return base_group(target) is not None
# The seed's 13 inputs.
DEFAULT_INPUTS: tuple[str, ...] = ("albedo", "normal", "depth", "direct", "lit")


def drop_order() -> tuple[str, ...]:
    """The input groups the fit's ablation may remove, cheapest pass to lose first (``Group.drop_rank``)."""
    rank = {g.name: g.drop_rank for g in GROUPS.values() if g.drop_rank is not None} | DERIVED_DROP_RANK
    return tuple(sorted(rank, key=lambda g: (rank[g], g)))


def group_size(name: str) -> int:
    if name in GROUPS:
        return GROUPS[name].size
    if name in DERIVED:
        return DERIVED[name][1]
    raise UserError(f"unknown channel group {name!r}; known: {', '.join(INPUT_GROUPS)}")


def parse_spec(spec: str | tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """Parse an input spec ("albedo,normal,...") into a tuple of group names, or raise UserError naming the fault."""
    if isinstance(spec, str):
        names = [s.strip() for s in spec.split(",")]
    else:
        names = [str(s).strip() for s in spec]
    if not names or names == [""]:
        raise UserError("channel spec is empty: name at least one input group, e.g. 'albedo,normal,depth,direct'")
    seen = set()
    for n in names:
        if n == "":
            raise UserError(f"channel spec {spec!r} has an empty group name")
        if n not in INPUT_GROUPS:
            raise UserError(f"channel spec names unknown input group {n!r}; known: {', '.join(INPUT_GROUPS)}")
        if n in seen:
            raise UserError(f"channel spec names group {n!r} twice")
        seen.add(n)
    return tuple(names)


def format_spec(spec: tuple[str, ...]) -> str:
    return ",".join(spec)


def input_channels(spec: tuple[str, ...]) -> int:
    return sum(group_size(g) for g in spec)


def required_groups(spec: tuple[str, ...]) -> tuple[str, ...]:
    """Stored groups needed to build the inputs of ``spec`` (derived groups expanded), in spec order."""
    out: list[str] = []
    for g in spec:
        for s in (DERIVED[g][0] if g in DERIVED else (g,)):
            if s not in out:
                out.append(s)
    return tuple(out)


# the group a one-render model reads: its every group, and its Combined image, come from one EEVEE render
# (docs/one_render.md; the Blender half's passes.ONE_RENDER_SETTINGS has its render settings)
ONE_RENDER_GROUPS: tuple[str, ...] = ("eevee_combined",)
# one-render kinds SSGI does not make: {a group only such a model read: the kind's name}
GONE_ONE_RENDER_KINDS: dict[str, str] = {"eevee_diffuse": "gi", "scene_gi": "gi", "eevee_local": "local"}
REBAKE = "re-bake with `cli.py bake --gi-samples N --one-render`"
REFIT = "fit a new one with `cli.py fit --one-render`, or train one on a `cli.py bake --one-render` dataset"


def one_render(spec: tuple[str, ...]) -> bool:
    """Whether a model of input ``spec`` is a one-render model (``ONE_RENDER_GROUPS``)."""
    return any(g in ONE_RENDER_GROUPS for g in required_groups(spec))


def gone_kind_of_model(spec) -> str | None:
    """The one-render kind SSGI does not make (``GONE_ONE_RENDER_KINDS``) that a model of input ``spec`` is of;
    None for another model."""
    groups = tuple(spec) + required_groups(tuple(spec))
    return next((GONE_ONE_RENDER_KINDS[g] for g in groups if g in GONE_ONE_RENDER_KINDS), None)


def gone_kind_of_bake(settings: dict) -> str | None:
    """The one-render kind SSGI does not bake that a dataset manifest's ``settings`` record (``eevee.one_render``:
    its ``kind``, or for a bake that recorded none, "gi" with ray tracing on, else "local"); None for another
    bake."""
    one = ((settings or {}).get("eevee") or {}).get("one_render") or {}
    if not one:
        return None
    kind = one.get("kind") or ("gi" if one.get("raytracing") else "local")
    return kind if kind in GONE_ONE_RENDER_KINDS.values() else None


def refuse_gone_model(spec, where) -> None:
    """UserError when a model of input ``spec`` (from ``where``) is of a one-render kind SSGI does not make."""
    kind = gone_kind_of_model(spec)
    if kind is not None:
        raise UserError(f"{where}: was made with the {kind!r} one-render kind, which SSGI no longer has; {REFIT}")


def refuse_gone_bake(settings: dict, where) -> None:
    """UserError when a dataset manifest's ``settings`` (of ``where``) record a one-render kind SSGI does not
    bake."""
    kind = gone_kind_of_bake(settings)
    if kind is not None:
        raise UserError(f"{where}: was baked with the {kind!r} one-render kind, which SSGI no longer has; {REBAKE}")


def required_passes(spec: tuple[str, ...]) -> tuple[str, ...]:
    """Blender view-layer pass flags (``use_pass_*``) needed for ``spec``."""
    return tuple(dict.fromkeys(GROUPS[g].blender_pass for g in required_groups(spec) if GROUPS[g].blender_pass))


def describe(groups=None) -> list[dict]:
    """The channel spec as plain data, for manifests and checkpoints: every stored group, or those of
    ``groups`` (what a dataset's samples hold), and the derived groups."""
    out = [dict(name=g.name, channels=list(g.channels), kind=g.kind, source=g.source, units=g.units, doc=g.doc)
           for g in GROUPS.values() if groups is None or g.name in groups]
    for name, (deps, size, doc) in DERIVED.items():
        out.append(dict(name=name, derived_from=list(deps), size=size, kind="light", doc=doc))
    return out
