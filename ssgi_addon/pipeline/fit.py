"""The fit stage (Fit to Scene): bake views of an artist's scene, fit a small model to them, report.

    summary = run(FitSceneConfig(blend="shot.blend", out="shot_ssgi.pt", views=24, minutes=15))

1. ``views.make_views`` adds jittered cameras to the open file (ssgi_addon/blender/views.py), which is saved as
   a copy ``MODEL.fit/views-TAG.blend`` (the .blend itself is never written);
2. ``bake_views`` bakes every camera of that copy at the plan's frames (``cli.py bake --scenes``, a child
   process; the baker resumes a half-done folder);
3. ``views.split_views`` holds out views by camera; ``model.learn.fit.fit`` searches the size, drops inputs and
   writes MODEL and its report (bpy-free).

A shot (``frames=(A, B)``, ``cli.py fit --frames A-B``): the views are baked at frames of A..B away
from ``views.N_WITHHELD`` withheld frames (ssgi_addon/blender/views.py), and after the fit
``render_withheld`` renders those frames as the node does (``RenderSession`` with the fitted model, at the
views' size and the file's EEVEE samples; the generic model on the same passes through the same working-
resolution predictor and compose), Cycles 1 spp + OIDN, and the reference (Cycles ``ref_samples`` spp + OIDN,
another seed), and the reference's own diffuse part + EEVEE's rest (the ceiling of a diffuse-part model);
``fit_report.score_withheld`` scores them into the report's ``withheld`` section, whose verdict
becomes the fit's. Scoring is not part of the fit (the model is written before it): ``minutes`` budgets the bake
and the training; the summary's ``withheld_minutes`` says what the scoring took.

TAG hashes the .blend's bytes and the plan: the same config on an unchanged file reuses the views already
baked; an edited file gets new views. ``data=DIR`` fits views baked before (roles from ``plan``, or: cameras
named ssgi.fit.view_* held out as make_views does). ``minutes`` is the whole budget, bake included.

The "Fit to Scene" operator runs ``cli.py fit --progress`` in a separate process (runtime/ui_jobs.py ``fit``,
through the one child launcher): EEVEE and Cycles renders of the bake must not block Blender's UI, and a GL
abort there cannot take Blender down.
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from ...model import channels as ch, cliargs, files
from ...model.dataset import folder as dataset_folder
from ...model.errors import UserError

MIN_FIT_MINUTES = 0.5
# The views' references: 16 spp + OIDN, not the baker's default (raw, up to 4096 spp), to keep the whole fit
# within its 15-minute budget; two seeds agree to 36.8-48.9 dB at this setting (docs/bake.md), far above the
# fitted models' error (25-35 dB).
FIT_REF_SAMPLES = 16
# a shot's lightmap trains for this share of the training budget, at most LIGHTMAP_MAX_S (its loss flattens after
# about 2 minutes on the benchmark shots, docs/fit.md)
LIGHTMAP_SHARE = 0.2
LIGHTMAP_MAX_S = 150.0
# a shot's reflection map (model/infer/reflmap.py) trains for this share of the training budget, at most REFLMAP_MAX_S
REFLMAP_SHARE = 0.06
REFLMAP_MAX_S = 60.0
# a second starting checkpoint for shot fits (the model shipped before the current one, commit b52fc1b; its
# metadata beside it): on the room shot it fine-tunes to 28.16 dB val (withheld frames 32.88 dB) where the shipped
# model reaches 25.87 (28.68), the same 5 minutes on the same views; on the living room the two are level
# (docs/fit.md). A shot fit probes both and goes on with the better on the val views.
FIT_START_MODEL = Path(__file__).resolve().parents[2] / "models" / "ssgi_fit_start.pt"


# ------------------------------------------------------------------------------------------------- the stage

def shot_defaults(cfg, init, shot: bool) -> tuple[list | None, float | None]:
    """(ladder, target PSNR) of a fit. A shot fit (``--frames``) with a starting checkpoint fine-tunes only that
    checkpoint (ladder ``[]``) towards the shot bar (``fit_report.SHOT_BAR_DB``) unless ``--target-psnr`` says
    otherwise: on the room shot, same 21 baked views and ~10.7 min of training, the scratch ladder (three scratch
    networks and the fine-tune sharing half the budget, the fine-tune 42 s; a scratch network kept) scored 31.41 dB
    on the withheld frames, the fine-tune alone (301 s) 32.72 dB. Still scenes, and a shot with nothing to
    fine-tune, search model.learn.fit.LADDER (smaller scratch networks predict 2-4x faster there, docs/fit.md):
    ladder None."""
    from ...model.evaluate.fit_report import SHOT_BAR_DB
    if shot and init:
        return [], (SHOT_BAR_DB if cfg.target_psnr is None else cfg.target_psnr)
    return None, cfg.target_psnr


# what a one-render fit's scratch networks read: every group of the one render (passes.ONE_RENDER_SETTINGS) but its
# Diffuse Direct pass, its emission statistics and the surround ray casts (no render), never the hard direct light or
# the other renders; they learn target ref_combined with head residual_combined, composed as EEVEE's GI-off Combined
# image + their prediction
ONE_RENDER_INPUTS = "albedo,normal,depth,emission,eevee_combined,glow,surround"
ONE_RENDER_HEAD = "residual_combined"


def one_render_ladder(target, shot: bool) -> tuple[list, float | None, str]:
    """(ladder, target PSNR, inputs) of a one-render fit: model.learn.fit.LADDER's scratch networks with head
    ONE_RENDER_HEAD, which starts from the one render's own image, on ONE_RENDER_INPUTS; a shot aims at the shot bar
    (fit_report.SHOT_BAR_DB) unless ``target`` says otherwise."""
    from ...model.evaluate.fit_report import SHOT_BAR_DB
    from ...model.learn.fit import LADDER
    rows = [[n, v, dict(o or {}, head=ONE_RENDER_HEAD)] for n, v, o in LADDER]
    return rows, (SHOT_BAR_DB if target is None and shot else target), ONE_RENDER_INPUTS


def starts_to_probe(cfg, init, shot: bool) -> list[str]:
    """The checkpoints a fit probes beside ``init`` (``FitConfig.also_init``): ``cfg.also_init`` when given, else for
    a shot fit that was given no ``--init`` the shipped fit start (FIT_START_MODEL, when present); never ``init``
    itself."""
    also = cfg.also_init
    if also is None:
        also = [str(FIT_START_MODEL)] if (not cfg.init and shot and init and FIT_START_MODEL.is_file()) else []
    return [str(a) for a in also if str(a) != str(init)]


@dataclass
class FitSceneConfig:
    """What ``run`` fits; the defaults are those of ``cli.py fit`` and the Fit panel."""
    out: str  # the checkpoint to write (.pt)
    blend: str | None = None  # the scene's .blend (not modified) ...
    data: str | None = None  # ... or views baked before
    plan: dict | str | None = None  # with data: the views_plan.json of that bake (a dict or the file)
    scene: str | None = None  # scene name (None: the file's active scene)
    views: int = 24  # about how many views to bake
    minutes: float = 15.0  # the whole time budget, bake included
    target_psnr: float | None = None  # None: the generic model's + 2 dB, or 30 dB without one
    size: tuple[int, int] | None = None  # views' size (None: views.default_size, 240 wide)
    init: str | None = None  # checkpoint to fine-tune from (None: the shipped model when present)
    # other checkpoints the fit may start from, chosen on the val views by the start probe (model.learn.fit
    # ``also_init``); None: a shot fit without --init probes the shipped fit start (FIT_START_MODEL) beside the
    # shipped model; [] probes nothing
    also_init: list | None = None
    drop_tol: float = 0.1  # drop an input pass when the val PSNR without it is at most this much lower (dB)
    ref_samples: int = FIT_REF_SAMPLES  # Cycles samples of the views' references (+ OIDN)
    crop: int | None = None  # training crop (None: FitConfig's)
    batch: int | None = None  # training batch (None: FitConfig's)
    min_run_s: float | None = None  # shortest training run worth starting (None: FitConfig's)
    threads: int | None = None  # torch threads
    seed: int = 0
    frames: tuple[int, int] | None = None  # a shot A..B: withhold whole frames for the test (module doc)
    # a shot fit's samples of the views' rest, which its reflection map corrects (a one-render fit: of its one render;
    # None: the scene's own EEVEE samples, as the node renders it; fewer make the bake cheaper)
    rest_samples: int | None = None
    # a shot fit also fits a lightmap (model/infer/lightmap.py) beside the model, when its views allow (off: --no-lightmap)
    lightmap: bool = True
    # ... and a reflection map (model/infer/reflmap.py) when its views show glossy surfaces: the views then hold
    # EEVEE's rest and Glossy Color at the node's settings (off: --no-reflmap)
    reflmap: bool = True
    # a one-render model (docs/one_render.md): the views hold only what one EEVEE render with ray tracing and fast
    # GI off gives (eevee_combined, eevee_local, albedo, normal, depth, emission, rest, gloss;
    # passes.ONE_RENDER_SETTINGS), scratch networks learn from its Combined image (ONE_RENDER_INPUTS), and each frame
    # of the node is that one render, without its Diffuse Direct pass
    one_render: bool = False
    command: str | None = None  # recorded in the checkpoint

    def check(self) -> None:
        """UserError naming the setting, before any work (nothing is written)."""
        if self.one_render and self.data:
            raise UserError("--one-render bakes its own views (--blend FILE): views baked before (--data) hold other "
                            "passes")
        out = Path(self.out).expanduser()
        if out.suffix != ".pt":
            raise UserError(f"--out {self.out}: the model file must end in .pt")
        if not out.resolve().parent.is_dir():
            raise UserError(f"--out {self.out}: folder {out.resolve().parent} does not exist")
        if not self.data and not self.blend:
            raise UserError("give --blend FILE (the scene to fit) or --data DIR (views baked before)")
        if self.views < 4:
            raise UserError(f"--views {self.views}: at least 4 views are needed (training, validation and test views)")
        if not (self.minutes > 0 and math.isfinite(self.minutes)):
            raise UserError(f"--minutes must be > 0 (got {self.minutes})")
        if self.ref_samples < 1:
            raise UserError(f"--ref-samples {self.ref_samples}: must be positive")
        if self.rest_samples is not None and (not (self.reflmap and self.frames) or self.rest_samples < 1):
            raise UserError(f"--rest-samples {self.rest_samples}: give a positive count, with a shot fit (--frames) "
                            "and its reflection map (only those bake the rest)")
        fault = cliargs.model_file_fault(self.init) if self.init else None
        if fault:  # before any baking
            raise UserError(f"--init {self.init}: {fault}")
        for a in self.also_init or ():
            fault = cliargs.model_file_fault(a)
            if fault:
                raise UserError(f"--also-init {a}: {fault}")
        if self.frames is not None:
            from ..blender.views import check_shot
            if len(self.frames) != 2:
                raise UserError(f"--frames {self.frames}: give the shot as A-B")
            check_shot(int(self.frames[0]), int(self.frames[1]))
        if isinstance(self.plan, str) and not Path(self.plan).is_file():
            raise UserError(f"--plan {self.plan}: no such file")


def work_dir(out) -> Path:
    """MODEL.fit/ beside the model: the views' .blend copy, the baked views, the plan, the candidates."""
    o = Path(out)
    return o.with_name(o.stem + ".fit")


def run(cfg: FitSceneConfig, progress=None, should_stop=None, log=None) -> dict:
    """Fit a model to a scene (module doc); returns the summary (model.learn.fit.fit's, plus bake_minutes,
    total_minutes, views, init). ``progress(dict)`` gets phase / message / progress; ``should_stop()`` is
    checked by the fit between training steps."""
    from ..blender import views as fviews

    log = log or _stderr
    cfg.check()
    t0 = time.perf_counter()
    out = Path(cfg.out).expanduser().resolve()
    work = work_dir(out)
    report = progress or (lambda d: None)
    bake_s = 0.0
    if cfg.data:
        data_dir = Path(cfg.data)
        plan = cfg.plan if isinstance(cfg.plan, dict) else (
            json.loads(Path(cfg.plan).read_text()) if cfg.plan else fviews.derive_plan(data_dir, cfg.seed))
    else:
        import bpy

        from ..blender.blendfile import check_blend, open_blend, pick_scene
        blend = check_blend(cfg.blend)
        open_blend(blend)
        scene = pick_scene(blend, cfg.scene)
        if bpy.context.window is not None and bpy.context.scene != scene:
            bpy.context.window.scene = scene
        report(dict(phase="views", message="adding jittered cameras", progress=0.0))
        plan = fviews.make_views(scene, cfg.views, cfg.seed, frames=tuple(cfg.frames) if cfg.frames else None)
        size = tuple(cfg.size) if cfg.size else fviews.default_size(scene)
        plan.update(size=list(size), blend=str(blend))
        if cfg.one_render:  # every group from the one GI-off render, at the scene's own samples
            plan["one_render"] = int(cfg.rest_samples or scene.eevee.taa_render_samples)
            from ..blender.passes import ONE_RENDER_SETTINGS
            from .bake import ONE_RENDER_KIND
            # (in the views' tag: views of another one render are not reused)
            plan["one_render_kind"] = ONE_RENDER_KIND
            plan["proxy_shadows"] = ONE_RENDER_SETTINGS["proxy_shadows"]
            plan["proxy_sides"] = ONE_RENDER_SETTINGS["proxy_sides"]
            plan["glossy"] = bool(has_glossy(scene))
        elif cfg.reflmap and plan.get("test_frames") and has_glossy(scene):
            # the views hold EEVEE's rest as the node renders it (at the scene's own samples) and its Glossy Color
            plan["rest_samples"] = int(cfg.rest_samples or scene.eevee.taa_render_samples)
        work.mkdir(parents=True, exist_ok=True)
        # views of THIS file with THESE settings: an edited scene gets new views, an unchanged one resumes
        tag = fviews.views_tag(blend, plan)
        wblend = work / f"views-{tag}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(wblend), copy=True)
        files.write_json(work / "views_plan.json", plan, default=str)
        data_dir = work / f"views-{tag}"
        report(dict(phase="bake", message=f"baking {len(plan['cameras']) * len(plan['frames'])} views", progress=0.0))
        bake_views(wblend, data_dir, plan, size, ref_samples=cfg.ref_samples, log=log,
                   rest_samples=plan.get("rest_samples", 0), one_render=plan.get("one_render", 0))
        bake_s = time.perf_counter() - t0
        log(f"fit: views baked in {bake_s / 60:.2f} min")
    train, val, test = fviews.split_views(data_dir, plan)
    cameras = (_view_cameras(None if cfg.data else scene, data_dir, plan, log)
               if cfg.lightmap and plan and plan.get("test_frames") else None)

    from ...model.learn import fit as mfit
    from ..blender.node import DEFAULT_MODEL
    # (a one-render fit starts from scratch: the shipped models read passes its views do not hold)
    init = cfg.init or (str(DEFAULT_MODEL) if DEFAULT_MODEL.is_file() and not cfg.one_render else None)
    withheld = plan.get("test_frames") if plan else None
    left = 60.0 * cfg.minutes - (time.perf_counter() - t0)
    floor = max(0.1 * 60.0 * cfg.minutes, 60.0 * MIN_FIT_MINUTES)  # a bake that ate the budget still gets a fit
    fit_minutes = max(left, floor) / 60.0
    lightmap_s = min(LIGHTMAP_MAX_S, LIGHTMAP_SHARE * 60.0 * fit_minutes) if cameras else 0.0
    # (a ref_combined model's corrects EEVEE's GI-off image only where the albedo is black: reflmap.apply_combined)
    glossy = (bool(cameras) and cfg.reflmap and plan.get("glossy", True)
              and "gloss" in dataset_folder.stored_groups(dataset_folder.open_folder(data_dir)))
    reflmap_s = min(REFLMAP_MAX_S, REFLMAP_SHARE * 60.0 * fit_minutes) if glossy else 0.0
    fit_minutes -= (lightmap_s + reflmap_s) / 60.0
    if left < floor:
        log(f"fit: the bake took {bake_s / 60:.2f} of {cfg.minutes:g} min; fitting gets {fit_minutes:.2f} min "
            "(the whole fit will run over the budget)")
    ladder, target = shot_defaults(cfg, init, bool(withheld))
    also = starts_to_probe(cfg, init, bool(withheld)) if not cfg.one_render else list(cfg.also_init or ())
    inputs = learn = None
    if cfg.one_render:
        ladder, target, inputs = one_render_ladder(target, bool(withheld))
        learn = ch.COMBINED_TARGET
    mcfg = mfit.FitConfig(data=str(data_dir), out=str(out), train_keys=train, val_keys=val, test_keys=test,
                          minutes=fit_minutes, target_psnr=target, init=init, threads=cfg.threads,
                          seed=cfg.seed, drop_tol=cfg.drop_tol, command=cfg.command,
                          target=learn, also_init=also, inputs=inputs)
    if ladder is not None:  # [] is a choice: only the starting checkpoint, fine-tuned
        mcfg.ladder = [list(r) for r in ladder]
    if cfg.crop:
        mcfg.crop = cfg.crop
    if cfg.batch:
        mcfg.batch = cfg.batch
    if cfg.min_run_s:
        mcfg.min_run_s = cfg.min_run_s
    res = mfit.fit(mcfg, callback=progress, should_stop=should_stop)
    if res.get("status") == "done":  # a new model is written: a lightmap beside it belongs to it, or there is none
        from ...model.infer import lightmap as ilm, reflmap as irm
        ilm.path_for(res["model"]).unlink(missing_ok=True)
        irm.path_for(res["model"]).unlink(missing_ok=True)
    if cameras and res.get("status") == "done":
        report(dict(phase="lightmap", message="fitting the shot's lightmap", progress=1.0))
        try:  # the model is written: a lightmap that cannot be fitted costs the shot its lightmap, not its model
            res["lightmap"] = fit_shot_lightmap(data_dir, cameras, train, val, res["model"],
                                                mcfg.target or ch.DIFFUSE_TARGET, lightmap_s, cfg.seed, log)
        except UserError as e:
            log(f"fit: no lightmap: {e}")
    if glossy and res.get("status") == "done":
        report(dict(phase="reflmap", message="fitting the shot's reflection map", progress=1.0))
        from ...model.infer.reflmap import corrects_combined
        try:  # as the lightmap: a map that cannot be fitted costs the shot its map, not its model
            res["reflmap"] = fit_shot_reflmap(data_dir, cameras, train, val, res["model"], reflmap_s, cfg.seed, log,
                                              combined=corrects_combined(mcfg.target or ch.DIFFUSE_TARGET))
        except UserError as e:
            log(f"fit: no reflection map: {e}")
    fit_s = time.perf_counter() - t0  # the fit: bake + training + its report (the budget's)
    w = None
    if withheld and res.get("status") == "done":
        from ...model.evaluate import fit_report
        report(dict(phase="withheld", message=f"rendering the {len(withheld)} withheld frames", progress=1.0))
        t1 = time.perf_counter()
        frames = render_withheld(plan.get("blend") or cfg.blend, plan, plan.get("size"), res["model"], init,
                                 cfg.ref_samples, work / "withheld", log=log)
        w = fit_report.score_withheld(frames)
        w.update(shot=plan["shot"], gap=plan.get("gap"), camera=plan["test_camera"], size=list(frames[0]["ref"].shape[1::-1]),
                 ref_samples=cfg.ref_samples, seconds=time.perf_counter() - t1, how=WITHHELD_HOW)
        res.update(withheld=w, verdict=fit_report.withheld_verdict(w))
        log(res["verdict"])
    res.update(bake_minutes=bake_s / 60.0, total_minutes=fit_s / 60.0, views=str(data_dir), init=init,
               withheld_minutes=(w["seconds"] / 60.0) if w else None)
    if res.get("report"):  # the bake's share (and a shot's withheld frames) belong in the report too
        from ...model.evaluate import fit_report
        rp = Path(res["report"])
        rep = json.loads(rp.read_text())
        rep.update(bake_minutes=res["bake_minutes"], total_minutes=res["total_minutes"])
        if w is not None:
            rep.update(withheld=w, verdict=res["verdict"], fit_verdict=rep.get("verdict"))
        if res.get("lightmap"):
            rep.update(lightmap=res["lightmap"])
        if res.get("reflmap"):
            rep.update(reflmap=res["reflmap"])
        fit_report.write(rep, res["model"])
    return res


# ------------------------------------------------------------------------------------------------- a shot

def _view_cameras(scene, data_dir, plan: dict, log) -> dict | None:
    """The views' camera matrices (``data_dir/cameras.json``; made from ``scene``, or from the views' .blend copy
    beside the folder, when missing), or None (logged) when they cannot be had: the fit then has no lightmap."""
    from ..blender import views as fviews
    cj = Path(data_dir) / "cameras.json"
    if cj.is_file():
        return json.loads(cj.read_text())
    size = plan.get("size")
    if scene is None:  # views baked before: their .blend copy lies beside the folder (views-TAG.blend)
        from ..blender.blendfile import open_blend, pick_scene
        wblend = Path(str(Path(data_dir)) + ".blend")
        if not wblend.is_file():
            log(f"fit: no lightmap: {cj} is missing and so is the views' .blend {wblend}")
            return None
        open_blend(wblend)
        scene = pick_scene(wblend, plan.get("scene"))
    return fviews.view_cameras(scene, data_dir, tuple(size) if size else None)


def fit_shot_lightmap(data_dir, cameras: dict, train, val, model, target: str, seconds: float, seed: int,
                      log) -> dict:
    """Fit the lightmap of a shot (model/learn/lightmap.py) and write it beside ``model`` (its weight chosen on the
    validation views; a weight of 0 is written too, and the node then ignores it). Returns its report."""
    from ...model.infer import lightmap as ilm
    from ...model.infer.predictor import load_predictor
    from ...model.learn import lightmap as llm
    predictor = load_predictor(model, runtime="torch")
    field, rep = llm.fit_lightmap(data_dir, cameras, train, val, predictor, target, seconds, seed=seed, log=log)
    path = field.save(ilm.path_for(model))
    rep.update(file=str(path))
    return rep


def fit_shot_reflmap(data_dir, cameras: dict, train, val, model, seconds: float, seed: int, log,
                     combined: bool = False) -> dict:
    """Fit the reflection map of a shot (model/learn/reflmap.py) and write it beside ``model`` (its weight chosen on
    the validation views; a weight of 0 is written too, and the node then ignores it; ``combined``: the model is a
    ref_combined one, whose image takes the map only where the albedo is black). Returns its report."""
    from ...model.infer import reflmap as irm
    from ...model.learn import reflmap as lrm
    field, rep = lrm.fit_reflmap(data_dir, cameras, train, val, seconds, seed=seed, log=log, combined=combined)
    path = field.save(irm.path_for(model))
    rep.update(file=str(path))
    return rep


def has_glossy(scene) -> bool:
    """Whether any visible mesh of ``scene`` has a material that reflects like a mirror or a metal: a Principled BSDF
    with metallic above 0.5, or roughness below 0.3 with its specular left on, or a Glossy / Metallic BSDF node,
    read from unlinked inputs (a linked input counts as glossy). What decides whether a shot fit bakes the rest and
    Glossy Color its reflection map needs (module reflmap): a diffuse room skips that cost."""
    def value(node, name, default):
        s = node.inputs.get(name)
        if s is None:
            return default
        return None if s.is_linked else float(s.default_value)

    for ob in scene.objects:
        if ob.type != "MESH" or ob.hide_render:
            continue
        for slot in ob.material_slots:
            m = slot.material
            if m is None or not m.use_nodes or m.node_tree is None:
                continue
            for n in m.node_tree.nodes:
                if n.bl_idname in ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic", "ShaderNodeBsdfMetallic"):
                    return True
                if n.bl_idname == "ShaderNodeBsdfPrincipled":
                    metal = value(n, "Metallic", 0.0)
                    rough = value(n, "Roughness", 0.5)
                    spec = value(n, "Specular IOR Level", 0.5)
                    if metal is None or metal > 0.5:
                        return True
                    if (rough is None or rough < 0.3) and (spec is None or spec > 0.0):
                        return True
    return False


WITHHELD_HOW = ("The fitted model through RenderSession (the SSGI node's render path: EEVEE passes at the file's "
                "samples, working resolution, compose with EEVEE's own rest, or a ref_combined model's with EEVEE's GI-off "
                "Combined image); the generic model on the same passes "
                "through the same predictor wrapper and compose.")


def render_withheld(blend, plan: dict, size, model, generic, ref_samples: int, out_dir=None, log=None) -> list[dict]:
    """Render a shot's withheld frames (``plan["test_frames"]``, camera ``plan["test_camera"]``) at ``size``
    (w, h): the SSGI node's image with ``model`` (RenderSession) and with ``generic`` (same passes), Cycles
    1 spp + OIDN, EEVEE's own render at the scene's settings (``eevee_gi``), the reference (Cycles ``ref_samples`` spp + OIDN, another seed) and, for a diffuse-part
    model, that reference's diffuse part composed with EEVEE's rest as the node composes (``oracle_diffuse``:
    what a perfect diffuse prediction would score; the rest's error no fit can remove) and, when the model has a
    lightmap, the fitted network alone without it (``fitted_network``). Returns [{frame, ref, mask, images,
    seconds}] for ``fit_report.score_withheld``; with ``out_dir``, a PNG sheet a frame (reference | fitted |
    [fitted network alone |] [generic |] EEVEE | Cycles 1 spp + OIDN)."""
    import numpy as np

    from ...model import channels as ch, images
    from ...model.infer.compose import needs
    from ...model.infer.workres import WorkingResolution
    from ..blender import passes
    from ..blender.blendfile import check_blend, open_blend, pick_scene
    from ..blender.compositor import setup_scene
    from ..blender.predictor import load_model
    from ..blender.scene_state import preserved
    from .render import RenderSession, compose

    log = log or _stderr
    blend = check_blend(blend)
    open_blend(blend)
    scene = pick_scene(blend, plan.get("scene"))
    scene.camera = scene.objects[plan["test_camera"]]
    if size:
        passes.set_resolution(scene, int(size[0]), int(size[1]))
    if generic:
        setup_scene(scene, str(generic))  # the passes the generic model needs too
    setup_scene(scene, str(model))
    session = RenderSession(scene, frames=list(plan["test_frames"]), model=str(model), write=False, keep_groups=True)
    gen = None
    if generic:
        gen = WorkingResolution(load_model(Path(generic)), session.working_res)
        session.groups = tuple(dict.fromkeys(session.groups + ch.required_groups(tuple(gen.spec)) + needs(gen.target)))
    out = []
    for info in session.iter_frames():
        g, f = info["groups"], int(info["frame"])
        imgs, secs = {"fitted": info["prediction"]}, {"fitted": info["t_total"]}
        if session.lightmap is not None:  # what the lightmap adds: the same network on the same passes without it
            t = time.perf_counter()
            imgs["fitted_network"] = compose(session.predict_network(g), g, scene.camera.data.clip_end, session.target)
            secs["fitted_network"] = info["t_passes"] + time.perf_counter() - t
        if gen is not None:
            t = time.perf_counter()
            want = ch.required_groups(tuple(gen.spec)) + ("normal", "depth", "albedo")
            p = gen.predict({k: g[k] for k in dict.fromkeys(want) if k in g})
            # (the generic model with EEVEE's own rest: the reflection map belongs to the fit)
            imgs["generic"] = compose(p, g | {"rest": g.get("rest_eevee", g.get("rest"))}, scene.camera.data.clip_end,
                                      gen.target)
            secs["generic"] = info["t_passes"] + time.perf_counter() - t
        with preserved(scene):  # EEVEE's own render of the frame, as the artist renders it without SSGI
            t = time.perf_counter()
            imgs["eevee_gi"] = passes.render_rest(scene)[1][..., :3]
            secs["eevee_gi"] = time.perf_counter() - t
        with preserved(scene):
            t = time.perf_counter()
            imgs["cycles_1spp_oidn"] = passes.render_cycles(scene, 1, seed=f, denoise=True)["ref"]
            secs["cycles_1spp_oidn"] = time.perf_counter() - t
            refs = passes.render_cycles(scene, int(ref_samples), seed=100003 + f, denoise=True,
                                        groups=("ref", "ref_diffuse"))
        ref = refs["ref"]
        if ch.adds_rest(session.target):  # the ceiling of any diffuse-part model: EEVEE's rest is kept
            imgs["oracle_diffuse"] = compose(refs["ref_diffuse"], g, scene.camera.data.clip_end, ch.DIFFUSE_TARGET)
            if "rest_eevee" in g:  # (with the reflection map, the ceiling above; EEVEE's own rest, this one)
                imgs["oracle_eevee_rest"] = compose(refs["ref_diffuse"], g | {"rest": g["rest_eevee"]},
                                                    scene.camera.data.clip_end, ch.DIFFUSE_TARGET)
        out.append(dict(frame=f, ref=ref, mask=images.geometry_mask(g["depth"], g["normal"]), images=imgs,
                        seconds=secs))
        log(f"fit: withheld frame {f}: " + ", ".join(f"{k} {v:.1f} s" for k, v in secs.items()))
        if out_dir is not None:
            Path(out_dir).mkdir(parents=True, exist_ok=True)
            row = [ref] + [imgs[k] for k in ("fitted", "fitted_network", "generic", "eevee_gi", "cycles_1spp_oidn")
                           if k in imgs]
            sheet = np.concatenate([np.pad(np.asarray(x, np.float32), ((0, 0), (0, 2), (0, 0))) for x in row], axis=1)
            images.write_png(Path(out_dir) / f"frame_{f:04d}.png", images.srgb8(sheet))
    return out


# ------------------------------------------------------------------------------------------------- bake

def bake_views(work_blend, data_dir, plan: dict, size, ref_samples: int | None = FIT_REF_SAMPLES, log=None,
               rest_samples: int = 0, one_render: int = 0) -> None:
    """Bake every camera of ``work_blend`` at the plan's frames with the baker (``cli.py bake --scenes``), in
    a child process (the baker resumes a half-done folder). The baker stays in this process's group and dies
    with it (runtime/launcher.py), so cancelling the fit ends the baker too. ``rest_samples``: the views also
    hold EEVEE's rest at that many samples (a fit that learns the rest). ``one_render``: a one-render bake
    (``cli.py bake --gi-samples N --one-render``) at that many samples."""
    from ..runtime import launcher
    cmd = launcher.cli_command("bake", "--scenes", str(work_blend), "--frames", ",".join(map(str, plan["frames"])),
                               "--size", f"{size[0]}x{size[1]}", "--out", str(data_dir))
    cmd += ["--ref-samples", str(ref_samples or FIT_REF_SAMPLES), "--denoise"]
    if one_render:
        cmd += ["--gi-samples", str(int(one_render)), "--one-render"]
    elif rest_samples:
        cmd += ["--rest-samples", str(int(rest_samples))]
    (log or _stderr)(f"fit: baking {len(plan['cameras']) * len(plan['frames'])} views: {' '.join(cmd[1:])}")
    launcher.run(cmd, env=launcher.cli_env(), new_group=False).check("baking the views")


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)
