"""The SSGI render path: for each frame, render EEVEE's passes -> predict -> composite with the artist's tree
-> write the frame where the scene's output settings say, in their format.

    summary = run(RenderConfig(blend="shot.blend", frames=[1, 2, 3]))      # the stage (cli.py render)
    session = RenderSession(scene, frames=[1, 2, 3], model=None, out=None)   # an open scene; checks first
    summary = session.run()                                                # or: for info in session.iter_frames()

Per frame:
1. ``passes.render_gbuffer(scene, groups)`` renders the direct-only G-buffer the model needs (plus depth and
   EEVEE's Combined for the world pixels). Every scene setting it changes (engine, EEVEE settings, light
   data, view-layer passes, output format) is put back afterwards by ``scene_state.preserved()``.
2. The model predicts linear HDR RGB, at the working resolution (``working_res``, the node's setting; default
   "auto": from 960 px wide 1/4 linear for a one-render model, else a working image 480 px wide) and upsampled with the full-resolution G-buffer (model/infer/workres.py). Pixels with no geometry (depth at the camera's clip end, or zero alpha)
   keep EEVEE's Combined colour. Alpha is not predicted: the node takes it from its Image input.
3. The prediction goes into the "SSGI Prediction" image (node.py). The pass render's result is saved as a
   multilayer EXR and loaded into Image nodes that stand in for the tree's Render Layers nodes (an Image
   node with a multilayer EXR has the same pass sockets; "Image" is called "Combined" there), so nodes that
   mix other passes keep working; the Render Layers nodes are muted, which makes the render composite-only
   (no 3D render). The tree is put back afterwards (blender/compositor.py ``standins``).
4. The composite (``Render Result``) is saved with the scene's image settings to a temporary name and
   renamed into place (``scene.render.frame_path``, or ``out``).

Renders are driven from a plain loop (``run``) or one frame per UI timer tick (the operator); never from
render handlers (that stopped or crashed animations, shared/blender5-notes.md). Cancelling between frames
keeps the frames already written. A ``render_pre`` handler (``on_render_pre``) puts the placeholder into the
node's image before any render that is not this path's, and says so on stderr.

With the temporal mode on (``temporal``: render_temporal.py) the prediction of step 2 is blended with the
reprojected stateless predictions of the frames before it. Over 400 lines by a few: the frame loop, its stage
and the plain-render guard share the session's conventions.
"""
from __future__ import annotations

import contextlib
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from ...model import channels as ch, files
from ...model.errors import UserError
from ...model.images import WORLD_DEPTH_FRACTION  # depth >= this x clip_end: no geometry
from ..blender import node as ssgi_node
from ..blender.compositor import save_multilayer, standins
from ..blender.predictor import load_model, missing_passes, pass_label
from ..blender.scene_state import preserved

# how many SSGI renders are running right now (the render_pre handler leaves those alone)
_ACTIVE = 0


def peak_rss_mb() -> float:
    """This process's peak resident memory so far (MiB)."""
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def log(msg: str) -> None:
    print(f"SSGI: {msg}", file=sys.stderr, flush=True)


def world_mask(groups: dict, clip_end: float) -> np.ndarray:
    """HxW bool: pixels where no geometry was hit (depth at the camera's clip end, or EEVEE alpha 0)."""
    m = groups["depth"][..., 0] >= WORLD_DEPTH_FRACTION * clip_end
    if "eevee" in groups and groups["eevee"].shape[-1] == 4:
        m |= groups["eevee"][..., 3] <= 0.0
    return m


def compose(pred: np.ndarray, groups: dict, clip_end: float, target: str = ch.TARGET_GROUP) -> np.ndarray:
    """The image the node shows (model/infer/compose.py): a diffuse-part model's prediction plus EEVEE's own other
    components, or a whole-image model's prediction with EEVEE's Combined colour where there is no geometry."""
    from ...model.infer.compose import compose as compose_
    return compose_(pred, groups, target, world_mask(groups, clip_end) if target == ch.TARGET_GROUP else None)


# --- output paths --------------------------------------------------------------------------------------

def output_path(scene, frame: int, out: str | None = None, single: bool = False) -> Path:
    """Where a frame goes: the scene's output path (``frame_path``), or ``out``. ``out`` with ``#`` or for
    several frames gets the frame number as Blender does; a single frame's ``out`` without ``#`` is used as
    the file name (plus the format's extension when the scene adds extensions and the name has none)."""
    r = scene.render
    if out is not None and single and "#" not in out:
        p = Path(os.path.abspath(os.path.expanduser(bpy.path.abspath(out))))
        if r.use_file_extension and not p.suffix:
            p = p.with_name(p.name + r.file_extension)
        return p
    if out is None:
        return Path(r.frame_path(frame=frame))
    old = r.filepath
    try:
        r.filepath = out if out.startswith("//") else os.path.abspath(os.path.expanduser(out))
        return Path(r.frame_path(frame=frame))
    finally:
        r.filepath = old


def atomic_save_render(scene, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    files.sweep(path.parent, owned=lambda n: n == path.name)  # a killed render's

    def save(tmp):
        bpy.data.images["Render Result"].save_render(str(tmp), scene=scene)
        if not tmp.is_file():
            raise UserError(f"{path}: Blender wrote no file (output format {scene.render.image_settings.file_format})")

    files.atomic_write(path, save)


# --- the session --------------------------------------------------------------------------------------

class RenderSession:
    """One SSGI render of ``frames`` of ``scene``. The constructor checks everything that can be wrong
    (model file, channel spec against the view layer's passes, SSGI node present, camera, output format)
    and raises UserError before changing anything."""

    def __init__(self, scene, frames=None, model: str | None = None, out: str | None = None, write: bool = True,
                 samples: int | None = None, save_passes: str | None = None, keep_groups: bool = False,
                 predictor=None, checks: bool = True, runtime: str | None = None, device: str | None = None,
                 pass_options: dict | None = None, working_res: str | None = None, temporal: str | None = None,
                 shot_start: int | None = None):
        self.scene = scene
        # the shot's first frame, before which the temporal mode blends nothing (None: scene.frame_start; a farm
        # worker whose range Blender's -s set gives the file's own, pipeline/farm.py)
        self.shot_start = shot_start
        self.frames = list(frames) if frames is not None else [scene.frame_current]
        if not self.frames:
            raise UserError("no frames to render")
        tree = scene.compositing_node_group
        self.nodes = ssgi_node.ssgi_nodes(tree)
        if not self.nodes:
            raise UserError(f"scene {scene.name!r} has no SSGI node in its compositor: add one (Add > SSGI), "
                            f"run 'Set up SSGI' (bpy.ops.ssgi.setup), or give `cli.py render` --setup")
        if scene.camera is None:
            raise UserError(f"scene {scene.name!r} has no camera")
        if write and scene.render.image_settings.media_type == "VIDEO":
            raise UserError(f"scene {scene.name!r} writes a video ({scene.render.image_settings.file_format}); "
                            f"SSGI renders write image files: choose an image format in Output Properties")
        self.model_path = ssgi_node.resolve_model(scene, model)
        self.predictor = predictor if predictor is not None else load_model(self.model_path, runtime, device)
        # how the emitter proxies of the model's one render were made (their shadows, their sides): the frame renders
        # them so
        from ..blender.passes import recorded_proxy_options
        self.proxy_options = recorded_proxy_options(getattr(self.predictor, "meta", None) or {})
        # the network runs at the working resolution (model/infer/workres.py; the node's setting by default)
        from ...model.infer.workres import WorkingResolution, parse_setting
        self.working_res = ssgi_node.resolve_working_res(scene, working_res)
        try:
            parse_setting(self.working_res)
        except UserError as e:
            raise UserError(f"SSGI node of scene {scene.name!r}: {e}") from None
        self.predictor = WorkingResolution(self.predictor, self.working_res)
        self.spec = tuple(self.predictor.spec)
        miss = missing_passes(scene, self.spec)
        if miss:
            raise UserError(
                f"model {self.model_path} (inputs {ch.format_spec(self.spec)}) needs pass(es) "
                f"{', '.join(pass_label(f) for f in miss)}, which view layer {scene.view_layers[0].name!r} of scene "
                f"{scene.name!r} does not render: run 'Set up SSGI' or enable them in View Layer > Passes")
        # normal too: it marks the pixels where nothing was hit for the depth normalisation, as in training;
        # and what the composition reads: EEVEE's own other components (rest, rendered last at the artist's own
        # settings) for a diffuse-part model, EEVEE's Combined for a whole-image model
        from ...model.infer.compose import needs
        self.target = self.predictor.target
        # what in the scene the SSGI path cannot handle (blender/scene_checks.py): fatal -> refused now;
        # ``checks=False`` only for measuring what a refused setup would render (benchmarks/bad_input.py)
        from ..blender.scene_checks import check_scene, node_label
        findings = check_scene(scene, self.spec, self.target) if checks else []
        fatal = [f for f in findings if f.fatal]
        if fatal:
            raise UserError(fatal[0].message + (f" (and {len(fatal) - 1} more problem(s))" if len(fatal) > 1 else ""))
        self.warnings = [f.message for f in findings]
        self.label = node_label(findings)
        for w in self.warnings:
            log(f"warning: {w}")
        # (EEVEE's direct-lit Combined `eevee` only for a whole-image model, whose composition reads it: a
        # one-render model's every group comes from the artist-settings render, docs/one_render.md)
        self.groups = tuple(dict.fromkeys(ch.required_groups(self.spec) + ("depth", "normal")
                                          + (("eevee",) if self.target == ch.TARGET_GROUP else ())
                                          + needs(self.target)))
        self.out = out
        self.write = write
        self.samples = int(samples) if samples else int(scene.eevee.taa_render_samples)
        self.save_passes = Path(save_passes) if save_passes else None
        self.keep_groups = keep_groups
        self.pass_options = dict(pass_options or {})  # more keywords of passes.render_gbuffer (benchmarks/pass_cost.py)
        # the temporal mode (render_temporal.py): blend earlier frames' reprojected predictions into each frame
        from . import render_temporal
        self.temporal = render_temporal.resolve(scene, temporal, len(self.frames))
        if self.temporal:
            self.groups += ("vector",)
        self.history = render_temporal.History(self) if self.temporal else None
        # a shot fit's lightmap beside the model (model/infer/lightmap.py): blended into the diffuse part
        from ...model.infer import lightmap
        self.lightmap = lightmap.load_beside(self.model_path) if ch.adds_part(self.target) else None
        if self.lightmap is not None:
            self.groups = tuple(dict.fromkeys(self.groups + self.lightmap.known))  # the direct light it adds back
            log(f"lightmap {lightmap.path_for(self.model_path).name}: weight {self.lightmap.lam:g}"
                + (f", known light {'+'.join(self.lightmap.known)}" if self.lightmap.known else ""))
        # ... and its reflection map (model/infer/reflmap.py): corrects EEVEE's rest where the Glossy Color is
        from ...model.infer import reflmap
        # (a ref_combined model's corrects EEVEE's GI-off image where the albedo is black: reflmap.apply_combined)
        self.reflmap = reflmap.load_beside(self.model_path) if ch.adds_part(self.target) else None
        if self.reflmap is not None:
            self.groups = tuple(dict.fromkeys(self.groups + ("gloss",)))
            log(f"reflection map {reflmap.path_for(self.model_path).name}: weight {self.reflmap.lam:g}")
        self.cancelled = False
        self.results: list[dict] = []

    @property
    def proxy_shadows(self) -> bool | None:
        """Whether the frames' emitter proxies cast shadows, as the model's bake recorded (None: no proxies)."""
        return self.proxy_options.get("proxy_shadows")

    @property
    def proxy_sides(self) -> str | None:
        """Which sides of an emitter get a proxy in the frames, as the model's bake recorded (None: no proxies)."""
        return self.proxy_options.get("proxy_sides")

    def _passes(self) -> dict:
        """The current frame's passes; called inside ``preserved``."""
        from ..blender import passes

        # (a shot's lightmap and reflection map read each pixel's own normal, where the geometric normals of a
        # smooth-shaded mesh would show its polygons: with either, the frame keeps EEVEE's Normal pass)
        # (and a boxmlp network reads the Normal pass, as its compositor nodes do: docs/compiled.md)
        compiled = (getattr(self.predictor, "arch", None) or {}).get("backbone") == "boxmlp"
        normals = {"normals": "pass"} if self.lightmap is not None or self.reflmap is not None or compiled else {}
        groups = passes.render_gbuffer(self.scene, self.groups, samples=self.samples, rest_samples=self.samples,
                                       **(self.proxy_options | normals | self.pass_options))
        missing = [g for g in self.groups if g not in groups]
        if missing:
            raise UserError(f"the pass render returned no {', '.join(missing)} for scene {self.scene.name!r}")
        if self.reflmap is not None:  # EEVEE's own rest stays beside the corrected one (rest_eevee: the fit report)
            from ..blender.views import camera_matrices
            c = camera_matrices(self.scene)
            # (a ref_combined model's base is EEVEE's GI-off image, corrected where the albedo is black)
            base = ch.base_group(self.target)
            from ...model.infer.reflmap import corrects_combined
            fix = self.reflmap.apply_combined if corrects_combined(self.target) else self.reflmap.apply
            groups[f"{base}_eevee"] = groups[base]
            groups[base] = fix(groups[base], groups, c["M"], c["P"])
        return groups

    def predict_network(self, groups: dict):
        """The network's prediction of a frame's passes (at the working resolution, brought back), without the
        lightmap."""
        want = ch.required_groups(self.spec) + ("normal", "depth", "albedo")
        # (the network reads EEVEE's own base, not the one the reflection map corrected: a ref_combined model's is an
        # input)
        base = ch.base_group(self.target)
        src = groups | ({base: groups[f"{base}_eevee"]} if f"{base}_eevee" in groups else {})
        return self.predictor.predict({g: src[g] for g in dict.fromkeys(want) if g in src})

    def _predict(self, groups: dict):
        pred = self.predict_network(groups)
        if self.lightmap is not None:  # the camera at the current frame, at the render size
            from ..blender.views import camera_matrices
            c = camera_matrices(self.scene)
            pred = self.lightmap.apply(pred, groups, c["M"], c["P"], factor=self.predictor.last_factor)
        return pred

    def _stateless(self, frame: int):
        """(groups, stateless prediction) of ``frame``: what its own render predicts (the temporal history)."""
        self.scene.frame_set(frame)
        with preserved(self.scene):
            groups = self._passes()
        return groups, self._predict(groups)

    def _frame(self, frame: int) -> dict:
        from ..blender import passes

        scene = self.scene
        info: dict = {"frame": frame}
        entries = self.history.prepare(frame, info) if self.history is not None else []
        scene.frame_set(frame)
        exr = None
        try:
            with preserved(scene):
                t0 = time.perf_counter()
                # the compositor's stand-in for the Render Layers node: the last pass render's own read-back file,
                # kept (passes.keep_render_file), not the Render Result saved a second time
                with passes.keep_render_file() as kept:
                    groups = self._passes()
                exr = kept.path
                info["t_pass_renders"] = dict(passes.last_timings)
                # (the last pass render made without EEVEE's shadows: nothing in it casts one, passes.casts_no_shadow)
                info["shadows_skipped"] = passes.last_render["shadows_skipped"]
                # (its Emission pass left out: no material of the file can emit, passes.render_rest)
                info["emission_skipped"] = passes.last_render["emission_skipped"]
                # (its normals from the Z pass, no Normal pass written: passes.render_gbuffer)
                info["normals_from_depth"] = passes.last_render["normals_from_depth"]
                info["t_passes"] = time.perf_counter() - t0
                info["rss_mb_passes"] = peak_rss_mb()
                t0 = time.perf_counter()
                if exr is None:  # (every pass render leaves one; kept for a path that would render none)
                    # made after the pass render (not during it), named by process: see docs/hard_cases.md
                    exr = str(files.scratch("ssgi-passes", ".exr"))
                    save_multilayer(scene, exr)
                info["t_standin"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            pred = self._predict(groups)
            if self.history is not None:
                stateless = pred
                pred = self.history.apply(frame, pred, groups, entries, info)
            rgb = compose(pred, groups, scene.camera.data.clip_end, self.target)
            info["t_predict"] = time.perf_counter() - t0
            info["working_factor"] = self.predictor.last_factor
            info["rss_mb_predict"] = peak_rss_mb()
            info["repaired_pixels"] = self.predictor.last_repaired  # non-finite inputs (normalize.repair)
            t0 = time.perf_counter()
            with preserved(scene):
                scene.render.use_compositing = True
                scene.render.use_sequencer = False
                ssgi_node.set_prediction(rgb, scene, frame, str(self.model_path))
                for n in self.nodes:
                    n.label = self.label
                with standins(scene, exr):
                    bpy.ops.render.render(scene=scene.name)
            info["t_composite"] = time.perf_counter() - t0
            if self.write:
                t0 = time.perf_counter()
                path = output_path(scene, frame, self.out, single=len(self.frames) == 1)
                atomic_save_render(scene, path)
                info["path"] = str(path)
                info["t_write"] = time.perf_counter() - t0
            if self.save_passes is not None:
                from ...model.dataset import exrio, folder as dataset
                self.save_passes.mkdir(parents=True, exist_ok=True)
                saved = dataset.sample_path(self.save_passes, dataset.sample_name(frame))
                exrio.write_sample(saved, {g: groups[g] for g in self.groups},
                                   half=False, header={"ssgi_frame": frame})
            if self.keep_groups:
                info["groups"] = groups
                info["prediction"] = rgb
                if self.history is not None:
                    info["stateless"] = compose(stateless, groups, scene.camera.data.clip_end, self.target)
                    info["stateless_part"] = stateless
        finally:
            if exr is not None:
                with contextlib.suppress(OSError):
                    os.unlink(exr)
        return info

    def iter_frames(self, should_cancel=None):
        """Render frame after frame, yielding each frame's info (timings, path). Stops between frames when
        ``should_cancel()`` is true; frames already written stay."""
        global _ACTIVE
        scene = self.scene
        frame0 = scene.frame_current
        _ACTIVE += 1
        try:
            for i, f in enumerate(self.frames):
                if should_cancel is not None and should_cancel():
                    self.cancelled = True
                    log(f"cancelled after {i} of {len(self.frames)} frame(s); written frames are kept")
                    break
                t0 = time.perf_counter()
                info = self._frame(f)
                info["t_total"] = time.perf_counter() - t0
                self.results.append(info)
                log(f"frame {f} ({i + 1}/{len(self.frames)}): passes {info['t_passes']:.2f} s, predict "
                    f"{info['t_predict']:.2f} s, composite {info['t_composite']:.2f} s"
                    + (f", wrote {info['path']}" if "path" in info else "")
                    + (f", repaired {info['repaired_pixels']} non-finite input pixel(s)" if info["repaired_pixels"] else "")
                    + (f", history {info['history_frames']} (rendered {info['history_rendered']})"
                       if info.get("history_rendered") else ""))
                yield info
            else:
                if self.history is not None:  # every frame rendered: the history is not needed for a resume
                    self.history.finish()
        finally:
            _ACTIVE -= 1
            if scene.frame_current != frame0:
                scene.frame_set(frame0)

    def run(self, should_cancel=None) -> dict:
        for _ in self.iter_frames(should_cancel):
            pass
        return self.summary()

    def summary(self) -> dict:
        res = [{k: v for k, v in r.items() if k not in ("groups", "prediction", "stateless", "stateless_part")} for r in self.results]
        return {"scene": self.scene.name, "model": str(self.model_path), "inputs": ch.format_spec(self.spec),
                "runtime": getattr(self.predictor, "runtime", "torch"), "model_file": str(self.predictor.path),
                "temporal": bool(self.temporal),
                "frames": [r["frame"] for r in res], "files": [r["path"] for r in res if "path" in r],
                "cancelled": self.cancelled, "warnings": list(self.warnings), "per_frame": res}


# --- the stage (cli.py render) ----------------------------------------------------------------------------

# image formats by file extension, as `blender -F` names them (EXR: single layer, as -F EXR)
FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".exr": "OPEN_EXR", ".tif": "TIFF", ".tiff": "TIFF",
           ".bmp": "BMP", ".webp": "WEBP", ".tga": "TARGA", ".hdr": "HDR", ".jp2": "JPEG2000", ".dpx": "DPX",
           ".cin": "CINEON", ".rgb": "IRIS"}
_SAME = {"OPEN_EXR_MULTILAYER": "OPEN_EXR", "TARGA_RAW": "TARGA"}  # formats an extension already stands for


def format_from_out(scene, out: str | None) -> str | None:
    """Let a known image extension of ``out`` choose the output format (the .blend is never written). Returns
    the format switched to, or None when the scene's format already matches or the extension is not known."""
    fmt = FORMATS.get(Path(out.replace("#", "0")).suffix.lower()) if out else None
    im = scene.render.image_settings
    if fmt is None or _SAME.get(im.file_format, im.file_format) == fmt:
        return None
    im.media_type = "IMAGE"  # a video scene offers no image formats until its media type is an image
    im.file_format = fmt
    return fmt



@dataclass
class RenderConfig:
    """What ``run`` renders; the defaults are those of ``cli.py render``."""
    blend: str  # the .blend file (never written)
    out: str | None = None  # output path, '#' for the frame number (None: the scene's output path)
    frames: list | None = None  # frames to render (None: the scene's current frame)
    model: str | None = None  # model checkpoint (None: the SSGI node's, the scene's or the shipped model)
    scene: str | None = None  # scene name (None: the file's active scene)
    samples: int | None = None  # EEVEE samples for the passes (None: the scene's render samples)
    setup: bool = False  # run Set up SSGI first (enable the passes, insert the node)
    save_passes: str | None = None  # also write each frame's G-buffer as SAVE_PASSES/NNNNNN.exr
    runtime: str | None = None  # what runs the network (model/infer/contract.RUNTIMES; None: preferences/auto)
    device: str | None = None  # where (contract.DEVICES; None: preferences/auto)
    working_res: str | None = None  # network resolution: auto|full|Nx|WxH (None: the SSGI node's, else auto)
    temporal: str | None = None  # auto|on|off: blend reprojected earlier frames (None: the SSGI node's, else auto)

    def check(self) -> None:
        from ..blender.blendfile import check_blend
        check_blend(self.blend)
        if self.frames is not None and not list(self.frames):
            raise UserError("--frames: no frames to render")
        if self.samples is not None and self.samples < 1:
            raise UserError(f"--samples {self.samples}: must be >= 1")
        if self.working_res is not None:
            from ...model.infer.workres import parse_setting
            try:
                parse_setting(self.working_res)
            except UserError as e:
                raise UserError(f"--working-res: {e}") from None
        if self.temporal is not None:
            from .render_temporal import check_setting
            check_setting(self.temporal, "--temporal")


def run(cfg: RenderConfig, progress=None, should_stop=None) -> dict:
    """Open the .blend, (set up SSGI), render the frames through the SSGI node; returns the session's summary.
    ``progress(dict)`` after each frame (done, total, progress, frame, path); ``should_stop()`` between frames."""
    from ..blender.blendfile import open_blend, pick_scene
    from ..blender.compositor import setup_scene

    cfg.check()
    blend = Path(cfg.blend).expanduser()
    open_blend(cfg.blend)
    scene = pick_scene(blend, cfg.scene)
    if cfg.setup:
        setup_scene(scene, cfg.model)
    before = scene.render.image_settings.file_format
    if format_from_out(scene, cfg.out):
        print(f"SSGI render: --out {cfg.out}: writing {scene.render.image_settings.file_format} (the scene's "
              f"output format is {before})", file=sys.stderr)
    frames = list(cfg.frames) if cfg.frames else [scene.frame_current]
    session = RenderSession(scene, frames, model=cfg.model, out=cfg.out, samples=cfg.samples,
                            save_passes=cfg.save_passes, runtime=cfg.runtime, device=cfg.device,
                            working_res=cfg.working_res, temporal=cfg.temporal)
    print(f"SSGI render: {blend.name} scene {scene.name!r}, {len(frames)} frame(s), model {session.model_path} "
          f"({session.predictor.runtime} on {session.predictor.device})",
          file=sys.stderr)
    for info in session.iter_frames(should_stop):
        if progress is not None:
            n = len(session.results)
            progress(dict(done=n, total=len(frames), progress=n / len(frames), frame=info["frame"],
                          path=info.get("path"), message=f"frame {info['frame']} done"))
    return session.summary()


# --- plain renders ---------------------------------------------------------------------------------------

@bpy.app.handlers.persistent
def on_render_pre(scene, *_args):
    """Before a render that is not the SSGI path's: the SSGI node must not show a stale prediction. Put the
    placeholder in its image, mark the node, and say so on stderr."""
    if _ACTIVE:
        return
    try:
        if not ssgi_node.is_set_up(scene):
            return
        nodes = ssgi_node.ssgi_nodes(scene.compositing_node_group)
        r = scene.render
        w = max(1, r.resolution_x * r.resolution_percentage // 100)
        h = max(1, r.resolution_y * r.resolution_percentage // 100)
        ssgi_node.set_placeholder(w, h)
        for n in nodes:
            n.label = "SSGI: placeholder, use Render SSGI"
        log(f"scene {scene.name!r} frame {scene.frame_current}: a plain render shows the SSGI node's magenta "
            f"placeholder, not a prediction. Press F12 / Ctrl+F12 (with the extension enabled they render SSGI), or "
            f"use Render > Render SSGI Image/Animation, bpy.ops.ssgi.render(), farm_render.py or 'cli.py render'.")
    except Exception as e:  # a handler must never break the artist's render
        log(f"render_pre check failed: {type(e).__name__}: {e}")
