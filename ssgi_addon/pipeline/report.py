"""The Blender side of the speed-against-error report: re-render each evaluation scene with each method and
time it (``cli.py report``; the "Report" button runs that command in a background process).

    raw, images = ReportRun(scenes, models, settings, log).run()     # then model.report.write_outputs

Evaluation scenes (``EvalScene``) come from a dataset folder (``dataset_scenes``): the validation scenes of
the split the models were trained with, one sample each, rebuilt from the sample's room seed (or reopened
from its .blend, camera and frame); the stored Cycles reference is the target. ``cli.py report --scenes``
first bakes the user's .blend files with the baker (ssgi_addon/bake.py) into OUT/data, then evaluates every
sample of that dataset. A sample's ``exposure`` (a factor the dataset applied to every light image after
rendering) is applied to every image rendered here too.

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
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import bpy
import numpy as np

from ...model import channels as ch
from ...model import images, metrics
from ...model.evaluate import analysis
from ...model.errors import UserError
from ..blender import blendfile, passes, room

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


# the G-buffer every method shares (the world pass is separate: see EvalScene.gbuffer)
RASTER_GROUPS = tuple(g for g in passes.EEVEE_GROUPS if g != "world")


def _needs_world(pred) -> bool:
    return "world" in ch.required_groups(tuple(pred.spec))


@dataclass
class EvalScene:
    name: str
    open: Callable[[], object]  # opens/builds the scene, sets camera and frame; returns the bpy scene
    ref: np.ndarray  # the stored Cycles reference (HxWx3): the target
    meta: dict = field(default_factory=dict)
    exposure: float = 1.0  # the dataset scaled every light image of this sample by this after rendering
    stored_eevee: np.ndarray | None = None  # the dataset's own EEVEE direct image: checks the rebuilt scene

    t_raster: float = 0.0  # seconds of the last gbuffer(): the direct-only raster ...
    t_world: float = 0.0  # ... and the world pass (0 when not rendered, or for a black world)

    def gbuffer(self, scene, samples: int = 1, world: bool = True) -> dict[str, np.ndarray]:
        """passes.render_gbuffer with the light groups scaled by ``exposure`` (as the dataset stored them). The
        world pass (a second render, only for an open scene) is timed apart: only models that read it pay it."""
        t0 = time.perf_counter()
        w = passes.render_world(scene, samples=samples) if world else None
        t1 = time.perf_counter()
        g = passes.render_gbuffer(scene, RASTER_GROUPS, samples=samples)
        self.t_world, self.t_raster = t1 - t0, time.perf_counter() - t1
        if w is not None:
            g["world"] = w
        if self.exposure != 1.0:
            k = np.float32(self.exposure)
            for lg in ("direct", "world"):
                if lg in g:
                    g[lg] = g[lg] * k
            g["eevee"] = np.concatenate([g["eevee"][..., :3] * k, g["eevee"][..., 3:]], -1)
        return g

    def light(self, img: np.ndarray) -> np.ndarray:
        """A rendered HxWx3 image scaled by ``exposure`` (light transport is linear in the lights' power)."""
        return img if self.exposure == 1.0 else img * np.float32(self.exposure)


@dataclass
class Settings:
    size: tuple[int, int] = (240, 135)
    spp: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64, 128)
    eevee_samples: int = 64
    eevee_high_samples: int = 64
    ref_samples: int = 32
    ref_denoise: bool = True
    gbuffer_samples: int = 1
    reference_scenes: int = 1
    predict_repeats: int = 3
    threads: int = 1
    sizes: tuple[str, ...] = ("240x135", "960x540", "1920x1080")
    temporal_frames: int = 4
    temporal_ref_samples: int = 256
    source: str = ""

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


# --------------------------------------------------------------------------------------------- scenes


def _room_opener(seed: int, size):
    def open_():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        room.build_room(int(seed), scene)
        passes.set_resolution(scene, *size)
        return scene
    return open_


def _blend_opener(path: Path, scene_name: str | None, camera: str | None, frame: int | None, size):
    def open_():
        blendfile.open_blend(path, arg=None)
        scene = blendfile.pick_scene(path, scene_name, arg=None)
        if camera:
            cam = scene.objects.get(camera)
            if cam is None or cam.type != "CAMERA":
                raise UserError(f"{path}: scene {scene.name!r} has no camera {camera!r}")
            scene.camera = cam
        if scene.camera is None:
            raise UserError(f"{path}: scene {scene.name!r} has no camera")
        if frame is not None:
            scene.frame_set(int(frame))
        passes.set_resolution(scene, *size)
        return scene
    return open_


def dataset_scenes(data_dir, model_ckpts=(), max_scenes: int | None = None, split: str = "val",
                   per_sample: bool = False):
    """(EvalScenes, Settings overrides, notes) of a dataset folder: one sample (the first key) of each
    evaluation scene, or every sample with ``per_sample``. ``split`` "val": the validation scenes recorded in the
    first model checkpoint that was trained on this very dataset (same manifest hash), else data.split_scenes'
    default split; "all": all."""
    from ...model.learn import data
    from ...model.dataset import exrio, folder as dataset

    root = Path(data_dir)
    m = dataset.open_folder(root, scenes=True)
    st = m.get("settings", {})
    if st.get("synthetic"):
        raise UserError(f"{root}: a synthetic dataset (model/synthetic.py) has no scenes to render")
    size = st.get("size") or (240, 135)
    size = tuple(int(v) for v in (size.lower().split("x") if isinstance(size, str) else size))
    by_scene: dict[str, list[str]] = {}
    for key, smp in sorted(m["samples"].items()):
        by_scene.setdefault(str(smp["scene"]), []).append(key)
    notes = []
    if split == "all":
        chosen = sorted(by_scene)
    else:
        sha = dataset.manifest_sha256(root)
        here = str(root.resolve())
        vals = [set((ck.get("dataset") or {}).get("split", {}).get("val") or ()) for ck in model_ckpts
                if (ck.get("dataset") or {}).get("manifest_sha256") == sha or (ck.get("dataset") or {}).get("path") == here]
        vals = [v & set(by_scene) for v in vals if v & set(by_scene)]
        chosen = None
        if vals:
            common = set.intersection(*vals)
            chosen = sorted(common or vals[0])
            notes.append(f"evaluation scenes: the validation scenes {'all ' if common else 'the first of '}{len(vals)} "
                         f"model checkpoint(s) record for this dataset (trained on none of them)")
        if chosen is None:
            if len(by_scene) < 2:
                chosen = sorted(by_scene)
                notes.append("the dataset has one scene: it is evaluated although no split keeps it out of training")
            else:
                chosen = data.split_scenes(by_scene, 0.2, 0)[1]
                notes.append("evaluation scenes: data.split_scenes(scenes, 0.2, seed 0)[1] (no given model records a "
                             "split of this very dataset)")
    # a model trained on another dataset may have trained on a scene of this one (the same room seed baked
    # twice): leave out every scene that any given model trained on
    trained = set()
    for ck in model_ckpts:
        trained |= set(((ck.get("dataset") or {}).get("split") or {}).get("train") or ())
    seen = [sc for sc in chosen if sc in trained]
    if seen and len(seen) < len(chosen):
        chosen = [sc for sc in chosen if sc not in trained]
        notes.append(f"left out {len(seen)} scene(s) that a given model trained on (another dataset's split): "
                     f"{', '.join(seen[:5])}{' ...' if len(seen) > 5 else ''}")
    elif seen:
        notes.append(f"every evaluation scene was a training scene of some given model ({', '.join(seen[:5])}): "
                     f"they are evaluated anyway, and that model's numbers flatter it")
    keys = [(sc, k) for sc in chosen for k in (by_scene[sc] if per_sample else by_scene[sc][:1])]
    if max_scenes:
        keys = keys[:max_scenes]
    out = []
    for sc, key in keys:
        meta = m["samples"][key]
        path = dataset.sample_path(root, key)
        stored = exrio.read_sample(path, (ch.TARGET_GROUP, "eevee"))
        if meta.get("blend"):
            cam = meta.get("camera") if isinstance(meta.get("camera"), str) else None
            opener = _blend_opener(Path(meta["blend"]), meta.get("blend_scene"), cam, meta.get("frame"), size)
            name = f"{sc}:{cam}:{meta.get('frame')}" if per_sample else sc
        elif "seed" in meta:
            opener = _room_opener(int(meta["seed"]), size)
            name = sc
        else:
            raise UserError(f"{root / 'manifest.json'}: sample {key} names neither a room seed nor a .blend file")
        out.append(EvalScene(name=name, open=opener, ref=stored[ch.TARGET_GROUP][..., :3], meta=dict(meta, key=key),
                             exposure=float(meta.get("exposure", 1.0)), stored_eevee=stored["eevee"][..., :3]))
    # a bake with an agreement target records each reference's own samples: the second reference takes as many
    spps = sorted(int(m["samples"][k]["reference"]["samples"]) for _sc, k in keys
                  if isinstance(m["samples"][k].get("reference"), dict))
    ref_samples = spps[len(spps) // 2] if spps else int(st.get("ref_samples") or 32)
    over = dict(size=size, ref_samples=ref_samples, ref_denoise=bool(st.get("denoise", False)),
                gbuffer_samples=int(st.get("eevee_samples") or 1), source=f"dataset {root}")
    return out, over, notes


# --------------------------------------------------------------------------------------------- renders


def _set(obj, dotted: str, value) -> None:
    *path, last = dotted.split(".")
    for p in path:
        obj = getattr(obj, p)
    setattr(obj, last, value)


def render_eevee_gi(scene, preset: str, samples: int) -> np.ndarray:
    """EEVEE's Combined image with ray tracing + fast GI on, the scene's own world and lights."""
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
    ee.light_threshold = 0.0  # as in the G-buffer: no light is culled, only the GI differs
    for k, v in GI_PRESETS[preset]["settings"].items():
        _set(ee, k, v)
    p = passes._render(scene)["Combined"]
    return np.stack([p[c] for c in "RGB"], axis=-1).astype(np.float32)


# --------------------------------------------------------------------------------------------- the run


class ReportRun:
    def __init__(self, scenes: list[EvalScene], models: list, settings: Settings, log=log, partial=None):
        """``models``: [(path, Predictor)]; ``partial(raw)``: called after each scene (save progress)."""
        if not scenes:
            raise UserError("no evaluation scene")
        self.scenes = scenes
        self.models = models
        self.s = settings
        self.log = log
        self.partial = partial
        self.raw: dict = dict(methods={}, scenes=[], notes=[])
        self.images: dict = {}
        self._warm = False
        self._world = any(_needs_world(p) for _, p in models)  # the world pass only when a model reads it
        self._steps = 0
        self._t0 = time.perf_counter()
        self.total_steps = len(scenes) * (2 + len(models) + len(GI_PRESETS) + 2 * len(settings.spp)) + settings.reference_scenes

    # --- bookkeeping
    def _step(self, what: str) -> None:
        self._steps += 1
        el = time.perf_counter() - self._t0
        frac = min(1.0, self._steps / max(1, self.total_steps))
        eta = el / frac * (1 - frac) if frac > 0 else math.nan
        self.log(f"progress {frac:.3f} eta {eta:.0f}s: {what}")

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

    def _warmup(self, scene) -> None:
        self.log("warm-up (untimed): EEVEE G-buffer and GI shader compile, OIDN and torch start-up")
        g = passes.render_gbuffer(scene, samples=self.s.gbuffer_samples)  # with the world pass
        for k in GI_PRESETS:
            render_eevee_gi(scene, k, 1)
        passes.render_cycles(scene, 1, seed=LADDER_SEED, denoise=True)
        for _, pred in self._model_keys.values():
            pred.predict(g)
        self._warm = True

    def run(self) -> tuple[dict, dict]:
        import torch
        torch.set_num_threads(int(self.s.threads))
        self._model_keys = {}
        for i, (path, pred) in enumerate(self.models):
            self._model_keys[f"model_{i}_{Path(path).stem}"] = (path, pred)
        self._register_methods()
        for i, es in enumerate(self.scenes):
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
        g = es.gbuffer(scene, s.gbuffer_samples, world=self._world)
        t_g, t_w = es.t_raster, es.t_world
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
        for key, (path, pred) in self._model_keys.items():
            ts, img = [], None
            for _ in range(max(1, s.predict_repeats)):
                img, t = _timed(pred.predict, g)
                ts.append(t)
            t_p = float(np.median(ts))
            t_gb = t_g + (t_w if _needs_world(pred) else 0.0)
            self._score(key, name, img, ref, mask, dict(gbuffer_s=t_gb, predict_s=t_p, whole_s=t_gb + t_p, own_s=t_p))
            self._step(f"{name}: {Path(path).name} {t_p * 1000:.0f} ms")
        for k in GI_PRESETS:
            img, t = _timed(render_eevee_gi, scene, k, s.eevee_samples if k == "default" else s.eevee_high_samples)
            self._score(f"eevee_gi_{k}", name, es.light(img), ref, mask, dict(render_s=t, whole_s=t, own_s=t))
            self._step(f"{name}: EEVEE GI {k} {t:.2f} s")
        for spp in s.spp:
            img, t_r = _timed(passes.render_cycles, scene, spp, seed=LADDER_SEED, denoise=False)
            self._score(f"cycles_{spp}", name, es.light(img["ref"]), ref, mask, dict(render_s=t_r, whole_s=t_r, own_s=t_r))
            self._step(f"{name}: Cycles {spp} spp {t_r:.2f} s")
            img, t_o = _timed(passes.render_cycles, scene, spp, seed=LADDER_SEED, denoise=True)
            self._score(f"cycles_oidn_{spp}", name, es.light(img["ref"]), ref, mask,
                        dict(render_s=t_r, denoise_s=max(0.0, t_o - t_r), whole_s=t_o, own_s=t_o))
            self._step(f"{name}: Cycles {spp} spp + OIDN {t_o:.2f} s")
        if index < s.reference_scenes:
            seed = int(es.meta.get("seed", 0)) + REF_SEED_OFFSET
            img, t = _timed(passes.render_cycles, scene, s.ref_samples, seed=seed, denoise=s.ref_denoise)
            self._score("reference", name, es.light(img["ref"]), ref, mask, dict(render_s=t, whole_s=t, own_s=t))
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
                fresh = bench.peak_memory(path, w, h, self.s.threads)
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
            g = es.gbuffer(scene, s.gbuffer_samples, world=self._world)
            seqs.setdefault("EEVEE direct light only", []).append(g["eevee"][..., :3])
            for key, (path, pred) in self._model_keys.items():
                seqs.setdefault(self.raw["methods"][key]["label"], []).append(pred.predict(g))
            if rung is not None:
                img = es.light(passes.render_cycles(scene, rung[0], seed=LADDER_SEED, denoise=True)["ref"])
                seqs.setdefault(f"Cycles {rung[0]} spp + OIDN (equal time)", []).append(img)
            refs.append(es.light(passes.render_cycles(scene, s.temporal_ref_samples, seed=int(es.meta.get("seed", 0)),
                                                      denoise=s.ref_denoise)["ref"]))
            self.log(f"temporal: frame {i + 1}/{frames}")
        res = {name: analysis.temporal_change(imgs, refs) for name, imgs in seqs.items()}
        return dict(scene=es.name, frames=frames, ref_samples=s.temporal_ref_samples, methods=res,
                    oidn_spp=rung[0] if rung else None, oidn_s=rung[1] if rung else None, model_s=t_model,
                    cycles_seed_note=f"fixed ({LADDER_SEED}) in every frame, as Blender's default "
                                     "(use_animated_seed off)",
                    move="pan 8 degrees and dolly 0.4 m along the camera's x axis, centred on the original view")
