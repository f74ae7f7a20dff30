"""The dataset baker: EEVEE direct-only G-buffer passes + a Cycles reference per sample, into OpenEXR.

``bake(...)`` is what ``cli.py bake`` and the "Bake Dataset" operator call. One Blender process bakes every
sample (EEVEE compiles its shaders once). Each sample is written to a temporary name and renamed when
complete, then the manifest is rewritten atomically; the same command run again skips complete samples and
redoes the rest. ``--shard i/n`` bakes every n-th sample into a shard manifest that ``cli.py merge`` joins.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import bpy

from ..model import channels as ch
from ..model import dataset as ds
from ..model import exrio
from ..model.errors import UserError
from . import passes, room

DEFAULT_SIZE = (240, 135)
# Cycles reference: measured in docs/bake.md (two seeds agree >= 40 dB PSNR at this setting).
DEFAULT_REF_SAMPLES = 16
DEFAULT_DENOISE = True
DEFAULT_EEVEE_SAMPLES = 1
EEVEE_SAMPLE_GROUPS = passes.EEVEE_GROUPS


def _settings(kind, size, ref_samples, denoise, eevee_samples, first_seed=None, scenes=None, frames=None):
    s = {"kind": kind, "size": [int(size[0]), int(size[1])], "ref_samples": int(ref_samples),
         "denoise": bool(denoise), "eevee_samples": int(eevee_samples),
         "diffuse_bounces": passes.DIFFUSE_BOUNCES, "half": True,
         "cycles": {"adaptive_sampling": False, "clamp_direct": 0.0, "clamp_indirect": 0.0,
                    "denoiser": "OPENIMAGEDENOISE" if denoise else None,
                    "denoising_input_passes": "RGB_ALBEDO_NORMAL" if denoise else None},
         "eevee": {"raytracing": False, "fast_gi": False, "light_threshold": 0.0, "world": "black",
                   "hard_lights": {"point_spot_radius": 0.0, "sun_angle": 0.0, "area_size_m": passes.AREA_LIGHT_SIZE}}}
    if first_seed is not None:
        s["first_seed"] = int(first_seed)
    if scenes is not None:
        s["scenes"] = [str(x) for x in scenes]
        s["frames"] = frames
    return s


def render_sample(scene, ref_samples: int, denoise: bool, eevee_samples: int, ref_seed: int = 0) -> tuple[dict, dict]:
    """Render one sample of ``scene``: ({group: HxWxC}, timings in seconds)."""
    t0 = time.perf_counter()
    groups = passes.render_gbuffer(scene, EEVEE_SAMPLE_GROUPS, samples=eevee_samples)
    t1 = time.perf_counter()
    groups.update(passes.render_cycles(scene, ref_samples, seed=ref_seed, denoise=denoise, groups=("ref",)))
    t2 = time.perf_counter()
    return groups, {"eevee_s": round(t1 - t0, 4), "cycles_s": round(t2 - t1, 4)}


def _room_jobs(count: int, first_seed: int):
    for i in range(count):
        seed = first_seed + i
        yield i, {"seed": seed, "scene": f"room-{seed}", "camera": f"{room.PREFIX}camera", "frame": 1}


def _open_blend(path: str):
    p = Path(path)
    if not p.is_file():
        raise UserError(f"--scenes {path}: no such .blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(p.resolve()), load_ui=False)
    except RuntimeError as e:
        raise UserError(f"--scenes {path}: not a readable .blend file ({str(e).strip().splitlines()[-1]})") from None
    return bpy.context.scene


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


def bake(out, count: int = 10, seed: int = 0, size=DEFAULT_SIZE, ref_samples: int = DEFAULT_REF_SAMPLES,
         denoise: bool = DEFAULT_DENOISE, eevee_samples: int = DEFAULT_EEVEE_SAMPLES, shard=None, scenes=None,
         frames=None, progress=None, should_stop=None) -> dict:
    """Bake a dataset folder (see module doc). ``progress(done, total, info)`` is called after each sample;
    ``should_stop()`` is checked between samples (the UI's Cancel). Returns a summary dict."""
    w, h = int(size[0]), int(size[1])
    if w <= 0 or h <= 0:
        raise UserError(f"--size {w}x{h}: width and height must be positive")
    if count is not None and count < 0:
        raise UserError(f"--count {count}: must be >= 0")
    if ref_samples <= 0:
        raise UserError(f"--ref-samples {ref_samples}: must be positive")
    if shard is not None and not (0 <= shard[0] < shard[1]):
        raise UserError(f"--shard {shard[0]}/{shard[1]}: need 0 <= i < n")
    out = Path(out)
    if scenes:
        settings = _settings("scenes", (w, h), ref_samples, denoise, eevee_samples, scenes=scenes,
                             frames=list(frames) if frames else None)
        for p in scenes:  # check every file before touching the folder
            if not Path(p).is_file():
                raise UserError(f"--scenes {p}: no such .blend file")
    else:
        settings = _settings("rooms", (w, h), ref_samples, denoise, eevee_samples, first_seed=seed)
    manifest = ds.prepare_folder(out, settings, bpy.app.version_string, shard)
    mname = ds.shard_manifest_name(shard)
    if shard is not None:
        manifest["settings"]["shard"] = list(shard)
    removed = ds.remove_temp_files(out)

    jobs = _scene_jobs(scenes, frames) if scenes else list(_room_jobs(count, seed))
    if shard is not None:
        jobs = [(i, info) for i, info in jobs if i % shard[1] == shard[0]]
    todo = [(i, info) for i, info in jobs
            if not (ds.sample_name(i) in manifest["samples"] and ds.sample_path(out, ds.sample_name(i)).is_file())]
    skipped = len(jobs) - len(todo)

    scene = None
    if not scenes:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
    current_blend = None
    done = 0
    t_start = time.perf_counter()
    for i, info in todo:
        if should_stop and should_stop():
            break
        name = ds.sample_name(i)
        if scenes:
            if info["blend"] != current_blend:
                scene = _open_blend(info["blend"])
                current_blend = info["blend"]
            cam = scene.objects.get(info["camera"])
            scene.camera = cam
            scene.frame_set(info["frame"])
        else:
            room.build_room(info["seed"], scene)
        passes.set_resolution(scene, w, h)
        groups, timings = render_sample(scene, ref_samples, denoise, eevee_samples, ref_seed=info["seed"])
        exrio.write_sample(ds.sample_path(out, name), groups, half=settings["half"],
                           header={"ssgi_seed": info["seed"], "ssgi_scene": info["scene"]})
        info = dict(info, timings=timings)
        manifest["samples"][name] = info
        manifest["samples"] = dict(sorted(manifest["samples"].items()))
        ds.write_manifest(out, manifest, mname)
        done += 1
        if progress:
            progress(done, len(todo), {"sample": name, **timings})
    if not todo:  # nothing to bake: still leave a manifest (e.g. --count 0)
        ds.write_manifest(out, manifest, mname)
    return {"out": str(out), "baked": done, "skipped": skipped, "total": len(jobs),
            "removed_temp_files": removed, "seconds": round(time.perf_counter() - t_start, 2),
            "manifest": mname}


# --------------------------------------------------------------------------------------------- command line


def run_bake(args) -> dict:
    from tqdm import tqdm

    from .render_cli import stdout_to_stderr
    bar = None

    def progress(done, total, info):
        nonlocal bar
        if bar is None:
            bar = tqdm(total=total, file=sys.stderr, unit="sample", desc="bake")
        bar.set_postfix(eevee=f"{info['eevee_s']:.1f}s", cycles=f"{info['cycles_s']:.1f}s")
        bar.update(1)

    with stdout_to_stderr():
        res = bake(args.out, count=args.count, seed=args.seed, size=args.size, ref_samples=args.ref_samples,
                   denoise=args.denoise, eevee_samples=args.eevee_samples, shard=args.shard, scenes=args.scenes,
                   frames=args.frames, progress=progress)
    if bar:
        bar.close()
    print(f"bake: {res['baked']} baked, {res['skipped']} already complete, {res['total']} in all -> {res['out']}",
          file=sys.stderr)
    return res


def run_verify(args) -> dict:
    problems = ds.verify(args.folder)
    for p in problems:
        print(f"verify: {p}", file=sys.stderr)
    n = 0
    try:
        n = len(ds.load_manifest(args.folder)["samples"])
    except UserError:
        pass
    if problems:
        raise UserError(f"{args.folder}: {len(problems)} problem(s) found (listed above)")
    print(f"verify: {args.folder}: {n} samples, all good", file=sys.stderr)
    return {"folder": str(args.folder), "samples": n, "problems": problems}


def run_merge(args) -> dict:
    res = ds.merge(args.folder)
    print(f"merge: {res['samples']} samples from {len(res['shards'])} shard manifest(s)", file=sys.stderr)
    return res


def run_preview(args) -> dict:
    res = ds.preview(args.folder, args.out, max_samples=args.max)
    print(f"preview: {res['sheet']} ({res['samples']} samples)", file=sys.stderr)
    return res


def register_cli(sub) -> None:
    from ..model import cliargs

    p = sub.add_parser("bake", help="bake random rooms (or your .blend scenes) into an EXR dataset",
                       description="Bake EEVEE direct-only G-buffer passes and a Cycles reference per sample into "
                                   "DIR/000000.exr ... + DIR/manifest.json. Run the same command again to resume.")
    p.add_argument("--out", required=True, metavar="DIR", help="dataset folder (created if missing)")
    p.add_argument("--count", type=cliargs.nonnegative_int, default=10, help="number of random rooms (default 10)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first room; room i uses seed+i (default 0)")
    p.add_argument("--size", type=cliargs.parse_size, default=DEFAULT_SIZE, metavar="WxH",
                   help="image size (default 240x135)")
    p.add_argument("--ref-samples", type=cliargs.positive_int, default=DEFAULT_REF_SAMPLES,
                   help=f"Cycles samples per pixel of the reference (default {DEFAULT_REF_SAMPLES})")
    p.add_argument("--denoise", dest="denoise", action="store_true", default=DEFAULT_DENOISE,
                   help="denoise the reference with OpenImageDenoise (albedo+normal)"
                        + (" (default)" if DEFAULT_DENOISE else ""))
    p.add_argument("--no-denoise", dest="denoise", action="store_false", help="raw path-traced reference")
    p.add_argument("--eevee-samples", type=cliargs.positive_int, default=DEFAULT_EEVEE_SAMPLES,
                   help=f"EEVEE render samples of the G-buffer (default {DEFAULT_EEVEE_SAMPLES})")
    p.add_argument("--shard", type=cliargs.parse_shard, default=None, metavar="i/n",
                   help="bake only samples i, i+n, ... (0-based) into a shard manifest; join with `merge`")
    p.add_argument("--scenes", nargs="+", metavar="FILE.blend", help="bake these scenes' cameras instead of rooms")
    p.add_argument("--frames", type=cliargs.parse_frames, default=None, metavar="A-B",
                   help="frames of --scenes to bake (default: each scene's current frame)")
    p.set_defaults(func=run_bake)

    v = sub.add_parser("verify", help="check a dataset folder", description="Check counts, channel names and "
                       "sizes, finite values and the manifest against the files; names each problem file.")
    v.add_argument("folder", metavar="DIR")
    v.set_defaults(func=run_verify)

    m = sub.add_parser("merge", help="join shard manifests into manifest.json",
                       description="Join the manifests of `bake --shard i/n` runs in DIR into DIR/manifest.json.")
    m.add_argument("folder", metavar="DIR")
    m.set_defaults(func=run_merge)

    pv = sub.add_parser("preview", help="write a contact sheet of a dataset",
                        description="Per sample: the passes and the reference, tonemapped, in one PNG.")
    pv.add_argument("folder", metavar="DIR")
    pv.add_argument("--out", required=True, metavar="SHEET.png")
    pv.add_argument("--max", type=cliargs.positive_int, default=12, help="samples to show (default 12)")
    pv.set_defaults(func=run_preview)
