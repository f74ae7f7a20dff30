"""The scenes the speed-against-error report evaluates (``EvalScene``), from a dataset folder.

``dataset_scenes`` picks the validation scenes of the split the models were trained with, one sample each,
rebuilt from the sample's room seed (or reopened from its .blend, camera and frame); the stored Cycles
reference is the target. A sample whose manifest entry records an ``exposure`` other than 1 (the scaling
the removed stand-in baker docs/model_minibake.py applied after rendering; ``cli.py bake`` never does) is
refused with a one-line error: re-bake such a folder with ``cli.py bake``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import bpy
import numpy as np

from ...model import channels as ch
from ...model.errors import UserError
from ..blender import blendfile, passes, room

# the G-buffer every method shares: one EEVEE render (the world pass, the soft direct light and the emitters'
# direct light are renders of their own, made only for the models that read them: see EvalScene.gbuffer)
RASTER_GROUPS = tuple(g for g in passes.EEVEE_GROUPS if g not in passes.OWN_RENDER_GROUPS + ("rest",))
EXTRA_GROUPS = tuple(g for g in passes.OWN_RENDER_GROUPS if g != "world")


@dataclass
class EvalScene:
    name: str
    open: Callable[[], object]  # opens/builds the scene, sets camera and frame; returns the bpy scene
    ref: np.ndarray  # the stored Cycles reference (HxWx3): the target
    meta: dict = field(default_factory=dict)
    stored_eevee: np.ndarray | None = None  # the dataset's own EEVEE direct image: checks the rebuilt scene

    t_raster: float = 0.0  # seconds of the last gbuffer(): the direct-only raster ...
    t_world: float = 0.0  # ... the world pass (0 when not rendered, or for a black world)
    t_extra: dict = field(default_factory=dict)  # ... and each extra group's render (EXTRA_GROUPS)

    def gbuffer(self, scene, samples: int = 1, world: bool = True, extra=()) -> dict[str, np.ndarray]:
        """passes.render_gbuffer of the scene. The world pass (a second render, only for an open scene) and the
        ``extra`` groups (EXTRA_GROUPS: a render each) are timed apart: only models that read them pay them."""
        t0 = time.perf_counter()
        w = passes.render_world(scene, samples=samples) if world else None
        t1 = time.perf_counter()
        g = passes.render_gbuffer(scene, RASTER_GROUPS, samples=samples)
        self.t_world, self.t_raster = t1 - t0, time.perf_counter() - t1
        self.t_extra = {}
        for e in extra:
            t = time.perf_counter()
            if e == "sky":  # the world's light at the normal just rendered: no render of its own
                from ..blender.sky import render_sky
                g["sky"] = render_sky(scene, g["normal"])
            else:
                g.update(passes.render_gbuffer(scene, (e,), samples=samples))
            self.t_extra[e] = time.perf_counter() - t
        if w is not None:
            g["world"] = w
        return g


# --------------------------------------------------------------------------------------------- scenes


def _room_opener(seed: int, size, mode: str = "diffuse"):
    def open_():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        room.build_room(int(seed), scene, mode=mode)
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
        recs = [data.recorded_split(ck.get("dataset"), sha, here) for ck in model_ckpts]
        vals = [set(r["val"]) & set(by_scene) for r in recs if r and set(r["val"]) & set(by_scene)]
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
        trained |= set((data.recorded_split(ck.get("dataset")) or {}).get("train") or ())
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
        if float(meta.get("exposure", 1.0)) != 1.0:
            raise UserError(f"{root / 'manifest.json'}: sample {key} records exposure {meta['exposure']!r}, a scaling "
                            "of the removed stand-in baker (docs/model_minibake.py); re-bake the folder with "
                            "`cli.py bake`")
        path = dataset.sample_path(root, key)
        stored = exrio.read_sample(path, (ch.TARGET_GROUP, "eevee"))
        if meta.get("blend"):
            cam = meta.get("camera") if isinstance(meta.get("camera"), str) else None
            opener = _blend_opener(Path(meta["blend"]), meta.get("blend_scene"), cam, meta.get("frame"), size)
            name = f"{sc}:{cam}:{meta.get('frame')}" if per_sample else sc
        elif "seed" in meta:
            opener = _room_opener(int(meta["seed"]), size, st.get("room_mode", "diffuse"))
            name = sc
        else:
            raise UserError(f"{root / 'manifest.json'}: sample {key} names neither a room seed nor a .blend file")
        out.append(EvalScene(name=name, open=opener, ref=stored[ch.TARGET_GROUP][..., :3], meta=dict(meta, key=key),
                             stored_eevee=stored["eevee"][..., :3]))
    # a bake with an agreement target records each reference's own samples: the second reference takes as many
    spps = sorted(int(m["samples"][k]["reference"]["samples"]) for _sc, k in keys
                  if isinstance(m["samples"][k].get("reference"), dict))
    ref_samples = spps[len(spps) // 2] if spps else int(st.get("ref_samples") or 32)
    over = dict(size=size, ref_samples=ref_samples, ref_denoise=bool(st.get("denoise", False)),
                gbuffer_samples=int(st.get("eevee_samples") or 1), source=f"dataset {root}")
    return out, over, notes

