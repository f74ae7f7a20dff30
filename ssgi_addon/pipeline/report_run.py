"""How the speed-against-error report renders and times each method on each evaluation scene (the report stage,
ssgi_addon/pipeline/report.py, runs it; the scenes come from report_scenes.py).

    raw, images = ReportRun(scenes, models, settings, progress=..., should_stop=...).run()

Per scene, in this order, each timed with ``time.perf_counter`` around the call that makes the image:

1. the EEVEE direct-only G-buffer (passes.render_gbuffer): "EEVEE direct light only" is its Combined image
   (time = this render); the learned methods predict from these passes (time = this render + prediction);
2. every model (predictor.load_predictor(...).predict), the median of ``predict_repeats`` calls;
3. EEVEE with its own GI (ray tracing + fast GI on, the scene's world and lights as they are), at each
   preset of ``GI_PRESETS``;
4. Cycles at each spp of the ladder, raw and with OIDN (albedo + normal); denoise time = OIDN render - raw;
5. on the first ``reference_scenes`` scenes, the reference again with another seed (its time; its PSNR
   against the target is the reference's self-agreement).

Before the first scene one untimed warm-up render of each EEVEE configuration, of Cycles + OIDN and one
prediction per model take the one-time costs (shader compile, OIDN and torch start-up) out of the timings.
After the scenes: ``scaling`` (prediction time and peak memory per model at each size, plus the G-buffer
raster and Cycles 1 spp + OIDN of the first scene at that size) and ``temporal`` (a short camera move).

Over 400 lines by a few: the run's steps for whole-image, diffuse-part and one-render models share one scene loop
and one timing bookkeeping (docs/architecture.md).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from ...model import channels as ch
from ...model import images, metrics
from ...model.evaluate import analysis
from ...model.infer.compose import compose, needs
from ...model.errors import UserError
from ..blender import passes
from .report_scenes import EXTRA_GROUPS, RASTER_GROUPS, EvalScene

# EEVEE's own GI: ray tracing + fast GI (horizon scan) on. "default": Blender's default tracing settings;
# "high": full-resolution tracing and fast GI, more rays and steps, best screen-trace quality.
GI_PRESETS: dict[str, dict] = {
    "default": dict(label="EEVEE ray tracing + fast GI, default quality", short="EEVEE GI", settings={}),
    "high": dict(label="EEVEE ray tracing + fast GI, high quality", short="EEVEE GI high", settings={
        "ray_tracing_options.resolution_scale": "1", "ray_tracing_options.screen_trace_quality": 1.0,
        "fast_gi_resolution": "1", "fast_gi_quality": 1.0, "fast_gi_step_count": 16, "fast_gi_ray_count": 4}),
}
GBUFFER_AGREEMENT_DB = 35.0  # below this the rebuilt scene is not the baked one (a note in the report)
LADDER_SEED = 7919  # Cycles seed of the ladder renders: not a seed the baker uses for references
REF_SEED_OFFSET = 104729  # the re-rendered reference uses the target's seed + this


def _one_render_light(pred) -> str | None:
    """The one-render group a one-render model reads (docs/one_render.md; ch.ONE_RENDER_GROUPS): eevee_combined;
    None for another model."""
    return next((g for g in ch.required_groups(tuple(pred.spec)) if g in ch.ONE_RENDER_GROUPS), None)


def _one_render(pred) -> bool:
    """A one-render model: every group it reads, and its rest or Combined image, come from one EEVEE render."""
    return _one_render_light(pred) is not None


def _diffuse_gbuffer(pred) -> bool:
    """A diffuse-part model that reads the G-buffer renders (world, soft direct, direct-only) beside the rest."""
    return _diffuse(pred) and not _one_render(pred)


def _needs_world(pred) -> bool:
    return "world" in ch.required_groups(tuple(pred.spec))


def _diffuse(pred) -> bool:
    """A model that predicts a part: its image is prediction + EEVEE's own rest, or + EEVEE's GI-off Combined image
    for a ref_combined model (infer/compose.py)."""
    return ch.adds_part(pred.target)


@dataclass(kw_only=True)
class Settings:
    """What ReportRun renders: the stage fills every field from its ReportConfig (where the defaults live) and
    from the dataset (size, reference, G-buffer samples)."""
    size: tuple[int, int]
    spp: tuple[int, ...]
    eevee_samples: int
    eevee_high_samples: int
    ssgi_samples: int = 16  # EEVEE samples of the SSGI passes (G-buffer and rest) for diffuse-part models
    ref_samples: int
    ref_denoise: bool
    gbuffer_samples: int
    reference_scenes: int
    predict_repeats: int = 3
    threads: int
    sizes: tuple[str, ...]
    temporal_frames: int
    temporal_ref_samples: int
    source: str

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        d["size"] = f"{self.size[0]}x{self.size[1]}"
        d["gi_presets"] = {k: dict(v["settings"], render_samples=self.eevee_samples if k == "default"
                                   else self.eevee_high_samples) for k, v in GI_PRESETS.items()}
        d["ladder_seed"] = LADDER_SEED
        return d


def log(msg: str) -> None:
    print(f"report: {msg}", file=sys.stderr, flush=True)


def _timed(fn, *a, **kw):
    t = time.perf_counter()
    r = fn(*a, **kw)
    return r, time.perf_counter() - t



# --------------------------------------------------------------------------------------------- renders


def _set(obj, dotted: str, value) -> None:
    *path, last = dotted.split(".")
    for p in path:
        obj = getattr(obj, p)
    setattr(obj, last, value)


def render_eevee_gi(scene, preset: str, samples: int, skip_unused_shadows: bool = False) -> np.ndarray:
    """EEVEE's Combined image with ray tracing + fast GI on, the scene's own world and lights. By default at the
    scene's own shadow setting, even where nothing casts a shadow: the baseline is EEVEE as the artist renders it;
    ``skip_unused_shadows`` makes it as SSGI's renders are made (``passes._render``: the same image, for a timing at
    equal savings)."""
    scene.render.engine = "BLENDER_EEVEE"
    ee = scene.eevee
    defaults = bpy.types.SceneEEVEE.bl_rna.properties
    for name in ("fast_gi_resolution", "fast_gi_quality", "fast_gi_step_count", "fast_gi_ray_count"):
        setattr(ee, name, defaults[name].default)
    rto = bpy.types.RaytraceEEVEE.bl_rna.properties
    for name in ("resolution_scale", "screen_trace_quality"):
        setattr(ee.ray_tracing_options, name, rto[name].default)
    ee.use_raytracing = True
    ee.use_fast_gi = True
    ee.fast_gi_method = "GLOBAL_ILLUMINATION"
    ee.taa_render_samples = int(samples)
    # as in the G-buffer: no light is culled, only the GI differs (threshold 0 needs the lamps' custom cutoff
    # distances: a closed room lit by one point light rendered black here until a G-buffer render left them set)
    passes.no_light_culled(scene)
    for k, v in GI_PRESETS[preset]["settings"].items():
        _set(ee, k, v)
    p = passes._render(scene, skip_unused_shadows=skip_unused_shadows)["Combined"]
    return np.stack([p[c] for c in "RGB"], axis=-1).astype(np.float32)


# --------------------------------------------------------------------------------------------- the run


class ReportRun:
    def __init__(self, scenes: list[EvalScene], models: list, settings: Settings, log=log, partial=None,
                 progress=None, should_stop=None):
        """``models``: [(path, Predictor)]; ``partial(raw)``: called after each scene (save progress);
        ``progress(dict)``: after each step (progress 0..1, eta_s, message); ``should_stop()``: checked between
        scenes (``cancelled`` is then True and ``run`` returns the scenes done)."""
        if not scenes:
            raise UserError("no evaluation scene")
        self.scenes = scenes
        self.models = models
        self.s = settings
        self.log = log
        self.partial = partial
        self.progress = progress
        self.should_stop = should_stop
        self.cancelled = False
        self.raw: dict = dict(methods={}, scenes=[], notes=[])
        self.images: dict = {}
        self._warm = False
        self._world = any(_needs_world(p) for _, p in models)  # the world pass only when a model reads it
        # ... and the soft direct light and the emitters' direct light too
        self._extra = tuple(e for e in EXTRA_GROUPS if any(e in ch.required_groups(tuple(p.spec)) for _, p in models))
        self._steps = 0
        self._t0 = time.perf_counter()
        n_ssgi = any(_diffuse_gbuffer(p) for _, p in models) + any(_one_render(p) for _, p in models)
        self.total_steps = (len(scenes) * (2 + n_ssgi + len(models) + len(GI_PRESETS) + 2 * len(settings.spp))
                            + settings.reference_scenes)

    # --- bookkeeping
    def _step(self, what: str) -> None:
        self._steps += 1
        el = time.perf_counter() - self._t0
        frac = min(1.0, self._steps / max(1, self.total_steps))
        eta = el / frac * (1 - frac) if frac > 0 else math.nan
        self.log(f"progress {frac:.3f} eta {eta:.0f}s: {what}")
        if self.progress is not None:
            self.progress(dict(phase="report", progress=round(frac, 4),
                               eta_s=None if not math.isfinite(eta) else round(eta, 1), message=what))

    def _method(self, key: str, **info) -> dict:
        m = self.raw["methods"].setdefault(key, dict(per_scene={}, **info))
        return m

    def _score(self, key: str, scene: str, img, ref, mask, times: dict) -> None:
        m = self.raw["methods"][key]
        r = metrics.score(img, ref, mask)
        r["time"] = {k: float(v) for k, v in times.items()}
        m["per_scene"][scene] = r
        self.images.setdefault(scene, {})[key] = np.asarray(img[..., :3], np.float32)

    def _register_methods(self) -> None:
        from ...model.learn import network
        self._method("eevee_direct", label="EEVEE direct light only", family="eevee_direct", short="EEVEE direct",
                     own_is_software_gl=True)
        for k, p in GI_PRESETS.items():
            self._method(f"eevee_gi_{k}", label=p["label"], family="eevee_gi", short=p["short"], own_is_software_gl=True)
        for key, (path, pred) in self._model_keys.items():
            kind = pred.kind
            params = network.count_params(pred.net)
            macs = network.macs_per_pixel(pred.net)
            variant = pred.arch.get("variant", "?")
            fam = "linear" if kind == "linear" else "ssgi"
            label = (f"linear regression [{Path(path).name}]" if fam == "linear"
                     else f"SSGI {variant} {params / 1000:.0f}k [{Path(path).name}]")
            self._method(key, label=label, family=fam, short=variant if fam == "ssgi" else "linear", model=str(path),
                         params=params, macs_per_px=macs, inputs=list(pred.spec),
                         best=pred.best, precision=pred.precision)
        for spp in self.s.spp:
            self._method(f"cycles_{spp}", label=f"Cycles {spp} spp", family="cycles", spp=spp)
            self._method(f"cycles_oidn_{spp}", label=f"Cycles {spp} spp + OIDN", family="cycles_oidn", spp=spp)
        self._method("reference", label=f"Cycles reference {self.s.ref_samples} spp"
                     + (" + OIDN" if self.s.ref_denoise else "") + " (another seed)", family="reference",
                     spp=self.s.ref_samples)

    def _one_render_groups(self, scene, samples: int) -> tuple[dict, dict]:
        """({one-render group: every group the one-render models of that kind read, and what they are composed with
        (the rest, or a ref_combined model's Combined image)}, {one-render group: seconds of its render}): one
        passes.render_gbuffer call per one-render group (``_one_render_light``; ray tracing and fast GI off, emitter
        proxies on), as the render path makes it (the proxies shadowed or
        not, on the sides, as the models' bakes recorded; models of a kind that disagree get the defaults)."""
        kinds: dict[str, list] = {}
        for _, p in self._model_keys.values():
            if (light := _one_render_light(p)) is not None:
                kinds.setdefault(light, []).append(p)
        out, secs = {}, {}
        for light, ones in kinds.items():
            want = tuple(dict.fromkeys(g for p in ones for g in ch.required_groups(tuple(p.spec)) + ("depth", "normal")
                                       + needs(p.target)))
            recorded = [passes.recorded_proxy_options(getattr(p, "meta", None) or {}) for p in ones]
            agreed = {k: vs.pop() for k in ("proxy_shadows", "proxy_sides", "proxy_shapes")
                      if len(vs := {r[k] for r in recorded if k in r}) == 1}
            out[light], secs[light] = _timed(passes.render_gbuffer, scene, want, samples=samples,
                                             rest_samples=samples, **agreed)
        return out, secs

    def _warmup(self, scene) -> None:
        self.log("warm-up (untimed): EEVEE G-buffer and GI shader compile, OIDN and torch start-up")
        g = passes.render_gbuffer(scene, RASTER_GROUPS + ("world",) + self._extra,
                                  samples=self.s.gbuffer_samples)  # with the world pass
        for k in GI_PRESETS:
            render_eevee_gi(scene, k, 1)
        passes.render_cycles(scene, 1, seed=LADDER_SEED, denoise=True)
        g1 = self._one_render_groups(scene, 1)[0]
        for _, pred in self._model_keys.values():
            pred.predict(g1[_one_render_light(pred)] if _one_render(pred) else g)
        if any(_diffuse(p) for _, p in self._model_keys.values()):
            passes.render_rest(scene, 1)  # the scene's own EEVEE settings compile their shaders too
        self._warm = True

    def run(self) -> tuple[dict, dict]:
        import torch
        torch.set_num_threads(int(self.s.threads))
        self._model_keys = {}
        for i, (path, pred) in enumerate(self.models):
            self._model_keys[f"model_{i}_{Path(path).stem}"] = (path, pred)
        self._register_methods()
        for i, es in enumerate(self.scenes):
            if self.should_stop is not None and self.should_stop():
                self.cancelled = True
                self.log(f"cancelled after {i} of {len(self.scenes)} scene(s)")
                break
            self.run_scene(i, es)
            if self.partial:
                self.partial(self.raw)
        return self.raw, self.images

    def run_scene(self, index: int, es: EvalScene) -> None:
        s = self.s
        self.log(f"scene {index + 1}/{len(self.scenes)}: {es.name}")
        scene = es.open()
        if not self._warm:
            self._warmup(scene)
        name = es.name
        self.raw["scenes"].append(name)
        g = es.gbuffer(scene, s.gbuffer_samples, world=self._world, extra=self._extra)
        t_g, t_w, t_x = es.t_raster, es.t_world, dict(es.t_extra)
        self._step(f"{name}: G-buffer {t_g:.2f} s, world pass {t_w:.2f} s")
        mask = images.geometry_mask(g["depth"], g["normal"])
        ref = es.ref
        if ref.shape[:2] != g["depth"].shape[:2]:
            raise UserError(f"scene {name}: the stored reference is {ref.shape[1]}x{ref.shape[0]}, the render "
                            f"{g['depth'].shape[1]}x{g['depth'].shape[0]}")
        self.images.setdefault(name, {})["ref"] = np.asarray(ref, np.float32)
        if es.stored_eevee is not None:  # is the scene rebuilt from its seed the one the dataset baked?
            agree = metrics.psnr(g["eevee"][..., :3], es.stored_eevee)
            self.raw.setdefault("gbuffer_agreement_db", {})[name] = agree
            self.raw["gbuffer_agreement_threshold_db"] = GBUFFER_AGREEMENT_DB
            if agree < GBUFFER_AGREEMENT_DB:
                self.raw["notes"].append(
                    f"scene {name}: the EEVEE direct image rendered here agrees with the dataset's only to {agree:.1f} dB "
                    f"(< {GBUFFER_AGREEMENT_DB} dB): the scene rebuilt from its seed may not be the one that was baked")
        self.raw.setdefault("geometry_fraction", {})[name] = float(mask.mean())
        self._score("eevee_direct", name, g["eevee"][..., :3], ref, mask,
                    dict(gbuffer_s=t_g, whole_s=t_g, own_s=t_g))
        gd, t_gd, t_wd, t_xd, t_rest = None, 0.0, 0.0, {}, 0.0
        if any(_diffuse_gbuffer(p) for _, p in self._model_keys.values()):
            # the SSGI path of a diffuse-part model: its G-buffer and EEVEE's own other components at the same
            # samples (their anti-aliasing must agree), as the render path renders them
            gd = es.gbuffer(scene, s.ssgi_samples, world=self._world, extra=self._extra)
            t_gd, t_wd, t_xd = es.t_raster, es.t_world, dict(es.t_extra)
            (gd["rest"], _beauty), t_rest = _timed(passes.render_rest, scene, s.ssgi_samples)
            self._step(f"{name}: SSGI passes at {s.ssgi_samples} samples: G-buffer {t_gd:.2f} s, rest {t_rest:.2f} s")
        g1, t_one = self._one_render_groups(scene, s.ssgi_samples)
        if g1:
            self._step(f"{name}: one-render passes at {s.ssgi_samples} samples {sum(t_one.values()):.2f} s")
        for key, (path, pred) in self._model_keys.items():
            gg = g1[_one_render_light(pred)] if _one_render(pred) else gd if _diffuse(pred) else g
            ts, img = [], None
            for _ in range(max(1, s.predict_repeats)):
                img, t = _timed(pred.predict, gg)
                ts.append(t)
            t_p = float(np.median(ts))
            d = _diffuse(pred)
            extra = sum(t for e, t in (t_xd if d else t_x).items() if e in ch.required_groups(tuple(pred.spec)))
            world_s = (t_wd if d else t_w) if _needs_world(pred) else 0.0
            times = dict(gbuffer_s=(t_gd if d else t_g) + world_s + extra, predict_s=t_p)
            if _one_render(pred):  # one render gives every group and the rest
                times = dict(gbuffer_s=0.0, predict_s=t_p, rest_s=t_one[_one_render_light(pred)])
                img = compose(img, gg, pred.target)
            elif _diffuse(pred):
                img = compose(img, gg, pred.target)
                times["rest_s"] = t_rest
            times.update(whole_s=sum(times.values()), own_s=t_p)
            self._score(key, name, img, ref, mask, times)
            self._step(f"{name}: {Path(path).name} {t_p * 1000:.0f} ms")
        for k in GI_PRESETS:
            img, t = _timed(render_eevee_gi, scene, k, s.eevee_samples if k == "default" else s.eevee_high_samples)
            self._score(f"eevee_gi_{k}", name, img, ref, mask, dict(render_s=t, whole_s=t, own_s=t))
            self._step(f"{name}: EEVEE GI {k} {t:.2f} s")
        for spp in s.spp:
            img, t_r = _timed(passes.render_cycles, scene, spp, seed=LADDER_SEED, denoise=False)
            self._score(f"cycles_{spp}", name, img["ref"], ref, mask, dict(render_s=t_r, whole_s=t_r, own_s=t_r))
            self._step(f"{name}: Cycles {spp} spp {t_r:.2f} s")
            img, t_o = _timed(passes.render_cycles, scene, spp, seed=LADDER_SEED, denoise=True)
            self._score(f"cycles_oidn_{spp}", name, img["ref"], ref, mask,
                        dict(render_s=t_r, denoise_s=max(0.0, t_o - t_r), whole_s=t_o, own_s=t_o))
            self._step(f"{name}: Cycles {spp} spp + OIDN {t_o:.2f} s")
        if index < s.reference_scenes:
            seed = int(es.meta.get("seed", 0)) + REF_SEED_OFFSET
            img, t = _timed(passes.render_cycles, scene, s.ref_samples, seed=seed, denoise=s.ref_denoise)
            self._score("reference", name, img["ref"], ref, mask, dict(render_s=t, whole_s=t, own_s=t))
            self._step(f"{name}: reference again {t:.2f} s")

    # --- after the scenes

    def scaling(self, es: EvalScene, sizes) -> dict:
        """Prediction time per model at each size (model.bench.time_predictor in this process, warm, on
        synthetic inputs: the weights and the image content do not change the work), its peak memory in a fresh
        process (bench.peak_memory), and the G-buffer raster and Cycles 1 spp + OIDN of scene ``es`` at each
        size."""
        from ...model.infer import bench
        from ...model.cliargs import parse_size

        out = dict(sizes=list(sizes), scene=es.name, models={}, gbuffer=[], cycles_1spp_oidn=[],
                   psnr_note=f"not measured: the evaluation data is {self.s.size[0]}x{self.s.size[1]} only")
        scene = es.open()
        for z in sizes:
            w, h = parse_size(z)
            passes.set_resolution(scene, w, h)
            _, t = _timed(passes.render_gbuffer, scene, RASTER_GROUPS, samples=self.s.gbuffer_samples)
            out["gbuffer"].append(dict(size=z, seconds=t))
            if self._world:
                _, t = _timed(passes.render_world, scene, samples=self.s.gbuffer_samples)
                out.setdefault("world_pass", []).append(dict(size=z, seconds=t))
            _, t = _timed(passes.render_cycles, scene, 1, seed=LADDER_SEED, denoise=True)
            out["cycles_1spp_oidn"].append(dict(size=z, seconds=t))
            self.log(f"scaling {z}: G-buffer {out['gbuffer'][-1]['seconds']:.2f} s, Cycles 1 spp + OIDN {t:.2f} s")
            for key, (path, pred) in self._model_keys.items():
                r = bench.time_predictor(pred, w, h, repeats=3 if w * h < 1e6 else 2)
                r["peak_mb_in_process"] = r.pop("peak_mb")
                setting = getattr(pred, "setting", "full")  # a WorkingResolution's (report.run wraps every model)
                fresh = bench.peak_memory(path, w, h, self.s.threads, working_res=setting if isinstance(setting, str)
                                          else f"{pred.factor(w, h)}x")
                r.update(peak_mb=fresh.get("peak_mb"), cold_ms=fresh.get("first_ms"))
                out["models"].setdefault(key, []).append(dict(size=z, **r))
                self.log(f"scaling {z}: {Path(path).name} {r['ms']:.0f} ms, peak +{r['peak_mb'] or 0:.0f} MB")
        return out

    def temporal(self, es: EvalScene, model_key: str | None, frames: int) -> dict:
        """A camera move (a slow pan and a sideways dolly) over ``frames`` frames of ``es``: per frame the
        G-buffer, every model, Cycles + OIDN at the rung closest in time to the default model, and a
        reference at ``temporal_ref_samples``; the mean frame-to-frame change of (image - reference)."""
        s = self.s
        summ = {k: analysis.summarize_method(m) for k, m in self.raw["methods"].items()}
        oidn = sorted((m["spp"], summ[k]["whole_s"]) for k, m in self.raw["methods"].items()
                      if m["family"] == "cycles_oidn" and summ.get(k))
        t_model = summ[model_key]["whole_s"] if model_key and summ.get(model_key) else None
        rung = analysis.closest_rung(oidn, t_model) if t_model else (oidn[0] if oidn else None)
        scene = es.open()
        cam = scene.camera
        x_axis = cam.matrix_world.to_3x3().col[0].copy()
        loc0, rot0 = cam.location.copy(), cam.rotation_euler.copy()
        seqs: dict[str, list] = {}
        refs = []
        for i in range(frames):
            t = i / max(1, frames - 1) - 0.5
            cam.location = loc0 + x_axis * (0.4 * t)
            cam.rotation_euler = (rot0.x, rot0.y, rot0.z + math.radians(8) * t)
            bpy.context.view_layer.update()
            g = es.gbuffer(scene, s.gbuffer_samples, world=self._world, extra=self._extra)
            seqs.setdefault("EEVEE direct light only", []).append(g["eevee"][..., :3])
            gd = None
            if any(_diffuse_gbuffer(p) for _, p in self._model_keys.values()):
                gd = es.gbuffer(scene, s.ssgi_samples, world=self._world, extra=self._extra)
                gd["rest"] = passes.render_rest(scene, s.ssgi_samples, proxies=True)[0]
            g1 = self._one_render_groups(scene, s.ssgi_samples)[0]
            for key, (path, pred) in self._model_keys.items():
                gp = g1[_one_render_light(pred)] if _one_render(pred) else gd
                img = compose(pred.predict(gp), gp, pred.target) if _diffuse(pred) else pred.predict(g)
                seqs.setdefault(self.raw["methods"][key]["label"], []).append(img)
            if rung is not None:
                img = passes.render_cycles(scene, rung[0], seed=LADDER_SEED, denoise=True)["ref"]
                seqs.setdefault(f"Cycles {rung[0]} spp + OIDN (equal time)", []).append(img)
            refs.append(passes.render_cycles(scene, s.temporal_ref_samples, seed=int(es.meta.get("seed", 0)),
                                             denoise=s.ref_denoise)["ref"])
            self.log(f"temporal: frame {i + 1}/{frames}")
        res = {name: analysis.temporal_change(imgs, refs) for name, imgs in seqs.items()}
        return dict(scene=es.name, frames=frames, ref_samples=s.temporal_ref_samples, methods=res,
                    oidn_spp=rung[0] if rung else None, oidn_s=rung[1] if rung else None, model_s=t_model,
                    cycles_seed_note=f"fixed ({LADDER_SEED}) in every frame, as Blender's default "
                                     "(use_animated_seed off)",
                    move="pan 8 degrees and dolly 0.4 m along the camera's x axis, centred on the original view")
