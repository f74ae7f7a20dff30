"""The dataset baker: EEVEE direct-only G-buffer passes + a Cycles reference per sample, into OpenEXR.

``run(BakeConfig(...))`` is the bake stage (``cli.py bake``, commands/bake.py; the report's ``--scenes``);
the "Bake Dataset" operator steps ``iter_bake`` on the main thread (runtime/ui_jobs.py ``bake``). One Blender process bakes every
sample (EEVEE compiles its shaders once). Each sample is written to a temporary name and renamed when
complete, then the manifest is rewritten atomically; the same command run again skips complete samples and
redoes the rest. ``--shard i/n`` bakes every n-th sample into a shard manifest that ``cli.py merge`` joins.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import bpy

from ...model.dataset import folder as ds
from ...model.dataset import exrio
from ...model import files
from ...model.errors import UserError
from ..blender import direct_light, passes, room
from ..blender.reference import DEFAULT_REF_SAMPLES, render_references, resolve_ref_target

DEFAULT_SIZE = (240, 135)
DEFAULT_DENOISE = False
DEFAULT_EEVEE_SAMPLES = 1
CYCLES_SAMPLE_GROUPS = ("ref", "ref_diffuse")
# what a new folder's samples hold: every input group and both references, not the artist-settings render rest
# (nor the render path's extras: the motion vectors are not a network input)
BAKE_INPUT_GROUPS = tuple(g for g in passes.INPUT_RENDER_GROUPS
                          if g not in ("rest",) + passes.EXTRA_GROUPS + passes.REST_ONLY_GROUPS)
# (sky, the world's L1 light at the normal: only the one-render bakes hold it)
BAKE_GROUPS = tuple(g for g in BAKE_INPUT_GROUPS if g not in passes.REST_LIGHT_GROUPS + ("sky",)) + CYCLES_SAMPLE_GROUPS
# a one-render bake (--gi-samples N --one-render; docs/one_render.md): what one-render models read, all of it from
# the artist-settings render at N samples with ray tracing and fast GI off and the emitter proxies on
# (passes.ONE_RENDER_SETTINGS): its Combined image (eevee_combined), the image composed from it (rest), albedo,
# normal, depth, emission, its Diffuse Direct pass (eevee_local) and Glossy Color (gloss; the fit's report, a shot's
# lightmap and reflection map); surround (ray casts); sky (the world's L1 light at the normal, no render of the
# scene); the 1-sample direct-only raster's direct, ao and eevee (groups every sample holds; cheap); the references.
# No world, direct_soft, emit_direct: those three renders are what a one-render model does without.
ONE_RENDER_BAKE_GROUPS = ("albedo", "normal", "depth", "direct", "ao", "emission", "eevee", "surround", "sky",
                          "eevee_combined", "rest") + CYCLES_SAMPLE_GROUPS + ("eevee_local", "gloss")
# the kind a one-render bake's manifest records (eevee.one_render.kind)
ONE_RENDER_KIND = "combined"


ROOM_MODES = room.MODES


def _settings(kind, size, ref_samples, denoise, eevee_samples, first_seed=None, scenes=None, frames=None,
              ref_target_db=None, mode="diffuse", gi_samples=0, rest_samples=0):
    s = _base_settings(kind, size, ref_samples, denoise, eevee_samples, first_seed, scenes, frames, ref_target_db,
                       mode)
    if rest_samples and not gi_samples:
        s["eevee"]["rest"] = {"samples": int(rest_samples), "mode": REST_MODE,
                              "render": "the scene's own EEVEE settings (passes.render_rest), as the node renders it",
                              "emitter_proxies": True}
    if gi_samples:
        one = passes.ONE_RENDER_SETTINGS
        s["eevee"]["one_render"] = {"gi_samples": int(gi_samples), "raytracing": False, "fast_gi": False,
                                    "kind": ONE_RENDER_KIND, "emitter_proxies": True,
                                    "emitter_proxy_shadows": one["proxy_shadows"],
                                    "emitter_proxy_sides": one["proxy_sides"],
                                    "emitter_proxy_shapes": one["proxy_shapes"],
                                    "groups_from_it": ["eevee_combined", "rest", *passes.SHARED_GROUPS,
                                                       "eevee_local", "gloss"],
                                    "rest": REST_MODE}
    return s


# how the rest group is made (passes.render_rest), as the manifests record it (eevee.rest.mode)
REST_MODE = "combined_minus_diffuse_color_times_diffuse_light_at_the_scenes_own_eevee_settings_no_lamp_culled"


def _base_settings(kind, size, ref_samples, denoise, eevee_samples, first_seed, scenes, frames, ref_target_db, mode):
    return ds.settings(kind, size, ref_samples, denoise, eevee_samples, diffuse_bounces=passes.DIFFUSE_BOUNCES,
                    ref_target_db=ref_target_db, first_seed=first_seed, scenes=scenes, frames=frames, room_mode=mode,
                    eevee={"raytracing": False, "fast_gi": False, "light_threshold": 0.0,
                           # (camera rays see the scene's world during the G-buffer render: passes._direct_only_world)
                           "world": "camera_rays_only",
                           # (passes.render_world)
                           "world_group": "diffuse_direct_lights_and_probes_hidden",
                           "hard_lights": {"point_spot_radius": 0.0, "sun_angle": 0.0,
                                           "area_size_m": passes.AREA_LIGHT_SIZE},
                           "direct_soft": {"samples": direct_light.SOFT_SAMPLES, "jitter": direct_light.SOFT_JITTER,
                                           "shadow_ray_count": direct_light.SOFT_RAY_COUNT,
                                           "shadow_step_count": direct_light.SOFT_STEP_COUNT, "point_sampled": True},
                           "emit_direct": {"renderer": "cycles", "samples": direct_light.EMITTER_SAMPLES,
                                           "denoise": True, "lamps": "hidden", "zeros_without_emitters": True},
                           "ref_diffuse": "cycles diffuse color x (diffuse direct + indirect), OIDN-denoised "
                                          "(compositor Denoise node, albedo + normal) when the reference is"})


def render_sample(scene, ref_samples: int, denoise: bool, eevee_samples: int, ref_seed: int = 0,
                  keep_sky: bool = True, eevee_groups=None, cycles_groups=("ref",),
                  ref_target_db: float | None = None, gi_samples: int = 0,
                  rest_samples: int = 0) -> tuple[dict, dict, dict]:
    """Render one sample of ``scene``: ({group: HxWxC}, timings in seconds, reference info). ``gi_samples``:
    the samples of the artist-settings render that gives eevee_combined, eevee_local and rest (a one-render bake).
    ``rest_samples``: also EEVEE's ``rest`` of the scene at its own settings at that many samples, as the node
    renders it (a render of its own; the other groups are as without it)."""
    t0 = time.perf_counter()
    eevee_groups = BAKE_INPUT_GROUPS if eevee_groups is None else tuple(eevee_groups)
    if rest_samples and "rest" not in eevee_groups:
        eevee_groups += ("rest",)
    # (a bake stores EEVEE's Normal pass: the render path's one-render frames take theirs from the depth)
    groups = passes.render_gbuffer(scene, eevee_groups, samples=eevee_samples, keep_sky=keep_sky,
                                   rest_samples=gi_samples or rest_samples or None, normals="pass")
    groups.pop("beauty", None)
    t1 = time.perf_counter()
    refs, ref_info = render_references(scene, ref_samples, ref_target_db, seed=ref_seed, denoise=denoise,
                                       groups=cycles_groups)
    groups.update(refs)
    t2 = time.perf_counter()
    return groups, {"eevee_s": round(t1 - t0, 4), "cycles_s": round(t2 - t1, 4)}, ref_info


def _room_jobs(count: int, first_seed: int):
    for i in range(count):
        seed = first_seed + i
        yield i, {"seed": seed, "scene": f"room-{seed}", "camera": f"{room.PREFIX}camera", "frame": 1}


def _open_blend(path: str):
    from ..blender.blendfile import open_blend
    return open_blend(path, arg="--scenes")


def _scene_jobs(scenes, frames):
    """(index, info) for each camera of each .blend at each frame; opens each file once to list them."""
    i = 0
    out = []
    for path in scenes:
        scene = _open_blend(path)
        cams = sorted(o.name for o in scene.objects if o.type == "CAMERA")
        if not cams:
            raise UserError(f"--scenes {path}: scene {scene.name!r} has no camera")
        fr = list(frames) if frames else [scene.frame_current]
        for cam in cams:
            for f in fr:
                out.append((i, {"seed": i, "scene": f"{Path(path).stem}", "blend": str(Path(path).resolve()),
                                "camera": cam, "frame": int(f)}))
                i += 1
    return out


def _check_args(w, h, count, ref_samples, shard, scenes, mode="diffuse"):
    if mode not in ROOM_MODES:
        raise UserError(f"--mode {mode!r}: not a room mode; known: {', '.join(ROOM_MODES)}")
    if w <= 0 or h <= 0:
        raise UserError(f"--size {w}x{h}: width and height must be positive")
    if count is not None and count < 0:
        raise UserError(f"--count {count}: must be >= 0")
    if ref_samples <= 0:
        raise UserError(f"--ref-samples {ref_samples}: must be positive")
    if shard is not None and not (0 <= shard[0] < shard[1]):
        raise UserError(f"--shard {shard[0]}/{shard[1]}: need 0 <= i < n")
    for p in scenes or ():  # check every file before touching the folder
        if not Path(p).is_file():
            raise UserError(f"--scenes {p}: no such .blend file")


def _complete(out, name, manifest) -> bool:
    """A sample is done when the manifest lists it and its file reads back whole at the dataset's size."""
    path = ds.sample_path(out, name)
    if name not in manifest["samples"] or not path.is_file():
        return False
    problems = ds.check_sample(path, manifest["settings"].get("size"), ds.stored_groups(manifest))
    for p in problems:
        print(f"bake: redoing {name}: {p}", file=sys.stderr)
    return not problems


def iter_bake(out, *, count: int, seed: int, size, ref_samples: int, denoise: bool, eevee_samples: int,
              shard=None, scenes=None, frames=None, scene=None, ref_target_db: float | None = None,
              mode: str = "diffuse", gi_samples: int = 0, rest_samples: int = 0):
    """Bake step by step (see module doc): a generator that yields one event dict after setting up and one
    after each sample, so that a caller on Blender's main thread (the Bake Dataset operator) can bake one
    sample per tick, and stop between any two samples leaving a valid, resumable dataset.

    Events: ``{"event": "start", "total", "todo", "skipped", "removed_temp_files"}``, then per sample
    ``{"event": "sample", "done", "todo", "sample", "seed", "eevee_s", "cycles_s", "eta_s"}``, then
    ``{"event": "done", **summary}``. Random rooms are built into ``scene`` (None: a fresh empty file, as
    the command line does; the operator passes a scratch scene so that the user's file is left alone)."""
    w, h = int(size[0]), int(size[1])
    _check_args(w, h, count, ref_samples, shard, scenes, mode)
    target = resolve_ref_target(ref_target_db, denoise)
    if target is not None and ref_samples < 2:  # no halves to compare: refuse before any work
        raise UserError(f"--ref-samples {ref_samples}: the {target:g} dB reference target compares two halves, so it "
                        "needs at least 2 samples; give --ref-samples 2 or more, or --ref-target-db 0 for a fixed count")
    if scenes and scene is not None:
        raise ValueError("--scenes opens each .blend file: it cannot bake into a given scene")
    out = Path(out)
    if scenes:
        settings = _settings("scenes", (w, h), ref_samples, denoise, eevee_samples, scenes=scenes,
                             frames=list(frames) if frames else None, ref_target_db=target, gi_samples=gi_samples,
                             rest_samples=rest_samples)
    else:
        settings = _settings("rooms", (w, h), ref_samples, denoise, eevee_samples, first_seed=seed,
                             ref_target_db=target, mode=mode, gi_samples=gi_samples, rest_samples=rest_samples)
    # list the jobs first: an unreadable .blend or a scene without a camera stops before the folder is touched
    jobs = _scene_jobs(scenes, frames) if scenes else list(_room_jobs(count, seed))
    if shard is not None:
        jobs = [(i, info) for i, info in jobs if i % shard[1] == shard[0]]
    manifest = ds.prepare_folder(out, settings, bpy.app.version_string, shard,
                                 groups=ONE_RENDER_BAKE_GROUPS if gi_samples else
                                 BAKE_GROUPS + (("rest",) + passes.REST_ONLY_GROUPS if rest_samples else ()))
    mname = ds.shard_manifest_name(shard)
    if shard is not None:
        manifest["settings"]["shard"] = list(shard)
    # a folder begun before the sky fix keeps its black sky in `eevee`, so that one dataset is one setting
    keep_sky = manifest["settings"].get("eevee", {}).get("world") != "black"
    # ... and a folder begun before a group existed (`world`; `emission`, `direct_soft`, `ref_diffuse`) goes on
    # without it
    # (a folder with rest holds the rest render's Glossy Color too, gloss, unless it was begun before gloss existed)
    eevee_groups = tuple(g for g in ds.stored_groups(manifest)
                         if g in BAKE_INPUT_GROUPS + ("rest",) + passes.REST_ONLY_GROUPS)
    gi_samples = int(manifest["settings"].get("eevee", {}).get("one_render", {}).get("gi_samples", 0))
    # (a folder goes on as it was begun: with rest at its samples, or without)
    rest_samples = int(manifest["settings"].get("eevee", {}).get("rest", {}).get("samples", 0))
    cycles_groups = tuple(g for g in ds.stored_groups(manifest) if g in CYCLES_SAMPLE_GROUPS)

    def owned(final_name):
        m = ds.SAMPLE_RE.match(final_name)
        return final_name == mname if m is None else (shard is None or int(m.group(1)) % shard[1] == shard[0])

    removed = len(files.sweep(out, owned))
    todo = [(i, info) for i, info in jobs if not _complete(out, ds.sample_name(i), manifest)]
    skipped = len(jobs) - len(todo)
    if not todo:  # nothing to bake: still leave a manifest (e.g. --count 0)
        ds.write_manifest(out, manifest, mname)
    yield {"event": "start", "total": len(jobs), "todo": len(todo), "skipped": skipped,
           "removed_temp_files": removed}

    if not scenes and scene is None:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
    current_blend = None
    done = 0
    t_start = time.perf_counter()
    for i, info in todo:
        name = ds.sample_name(i)
        if scenes:
            if info["blend"] != current_blend:
                scene = _open_blend(info["blend"])
                current_blend = info["blend"]
            scene.camera = scene.objects.get(info["camera"])
            scene.frame_set(info["frame"])
        else:
            room.build_room(info["seed"], scene, mode=mode)
        passes.set_resolution(scene, w, h)
        kept = len(manifest["samples"])
        try:
            groups, timings, ref_info = render_sample(scene, ref_samples, denoise, eevee_samples,
                                                      ref_seed=info["seed"], keep_sky=keep_sky,
                                                      eevee_groups=eevee_groups, cycles_groups=cycles_groups,
                                                      ref_target_db=target, gi_samples=gi_samples,
                                                      rest_samples=rest_samples)
            exrio.write_sample(ds.sample_path(out, name), groups, half=settings["half"],
                               header={"ssgi_seed": info["seed"], "ssgi_scene": info["scene"]})
            manifest["samples"][name] = dict(info, timings=timings, reference=ref_info)
            manifest["samples"] = dict(sorted(manifest["samples"].items()))
            ds.write_manifest(out, manifest, mname)
        except OSError as e:  # disk full, quota, folder gone: nothing half-written is left under a final name
            raise UserError(f"--out {out}: could not bake sample {name}: {e}. The {kept} sample(s) listed in "
                            f"{mname} are complete; free space or mend the folder, then run the same command "
                            f"again to resume") from None
        done += 1
        elapsed = time.perf_counter() - t_start
        if target is not None and ref_info["agreement_db"] < target:
            print(f"bake: {name}: the reference reached --ref-samples {ref_samples} at an estimated "
                  f"{ref_info['agreement_db']:.1f} dB, under the {target:g} dB target", file=sys.stderr)
        yield {"event": "sample", "done": done, "todo": len(todo), "progress": round(done / len(todo), 4),
               "sample": name, "seed": info["seed"],
               **timings, "ref_samples": ref_info["samples"], "ref_agreement_db": ref_info["agreement_db"],
               "eta_s": round(elapsed / done * (len(todo) - done), 1)}
    yield {"event": "done", "out": str(out), "baked": done, "skipped": skipped, "total": len(jobs),
           "removed_temp_files": removed, "seconds": round(time.perf_counter() - t_start, 2), "manifest": mname}


@dataclass
class BakeConfig:
    """What ``run`` bakes; the defaults are those of ``cli.py bake`` and the Dataset panel."""
    out: str  # dataset folder (created if missing)
    count: int = 10  # random rooms; room i uses seed + i
    seed: int = 0  # seed of the first room
    size: tuple[int, int] = DEFAULT_SIZE
    ref_samples: int = DEFAULT_REF_SAMPLES  # the most a reference takes (exactly this with no target)
    ref_target_db: float | None = None  # None: DEFAULT_REF_TARGET_DB raw, a fixed count with denoise (resolve_ref_target)
    denoise: bool = DEFAULT_DENOISE  # denoise the reference with OIDN
    eevee_samples: int = DEFAULT_EEVEE_SAMPLES  # EEVEE render samples of the G-buffer
    shard: tuple[int, int] | None = None  # (i, n): bake samples i, i+n, ... into a shard manifest
    scenes: list | None = None  # bake these .blend files' cameras instead of rooms
    frames: list | None = None  # frames of the scenes (None: each scene's current frame)
    mode: str = "diffuse"  # random rooms: "diffuse" (the seed's) or "artist" (room.MODES; docs/artist_rooms.md)
    one_render: bool = False  # a one-render bake (docs/one_render.md) ...
    gi_samples: int = 0  # ... its artist-settings render at this many samples
    rest_samples: int = 0  # > 0: the samples also hold EEVEE's rest at the scene's settings at this many samples

    def check(self) -> None:
        """UserError naming the setting, before the folder is touched."""
        _check_args(int(self.size[0]), int(self.size[1]), self.count, self.ref_samples, self.shard, self.scenes,
                    self.mode)
        if self.one_render and not self.gi_samples:
            raise UserError("--one-render needs --gi-samples N (the samples of the one render)")
        if self.gi_samples and not self.one_render:
            raise UserError(f"--gi-samples {self.gi_samples}: the samples of a one-render bake's render; give "
                            "--one-render too")
        resolve_ref_target(self.ref_target_db, self.denoise)


def run(cfg: BakeConfig, progress=None, should_stop=None, on_start=None, scene=None) -> dict:
    """Bake a dataset folder in one go (``iter_bake`` to the end). ``on_start(event)`` is called once the folder
    is ready, ``progress(event)`` after each sample (done, todo, progress, sample, timings, eta_s);
    ``should_stop()`` is checked between samples. Returns a summary dict."""
    cfg.check()
    gen = iter_bake(cfg.out, count=cfg.count, seed=cfg.seed, size=cfg.size, ref_samples=cfg.ref_samples,
                    denoise=cfg.denoise, eevee_samples=cfg.eevee_samples, shard=cfg.shard, scenes=cfg.scenes,
                    frames=cfg.frames, scene=scene, ref_target_db=cfg.ref_target_db, mode=cfg.mode,
                    gi_samples=cfg.gi_samples if cfg.one_render else 0, rest_samples=cfg.rest_samples)
    start = next(gen)
    if on_start:
        on_start(start)
    summary, baked, t_start = None, 0, time.perf_counter()
    while not (should_stop and should_stop()):
        ev = next(gen)
        if ev["event"] == "done":
            summary = ev
            break
        baked = ev["done"]
        if progress:
            progress(ev)
    if summary is None:  # stopped between two samples: what is written stays valid and resumable
        gen.close()
        summary = {"out": str(cfg.out), "baked": baked, "skipped": start["skipped"], "total": start["total"],
                   "removed_temp_files": start["removed_temp_files"],
                   "seconds": round(time.perf_counter() - t_start, 2), "manifest": ds.shard_manifest_name(cfg.shard),
                   "cancelled": True}
    summary = {k: v for k, v in summary.items() if k != "event"}
    summary.setdefault("cancelled", False)
    return summary


