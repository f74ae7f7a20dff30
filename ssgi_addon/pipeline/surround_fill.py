"""Add the ``surround`` group (ssgi_addon/blender/surround.py), or the ``sky`` group (ssgi_addon/blender/sky.py), to
a dataset folder baked before it held it.

    summary = add_group("data/artist1")         # scripts/add_surround.py DIR [DIR ...]
    summary = add_group("data/artist1", "sky")  # scripts/add_surround.py --group sky DIR [DIR ...]

Neither group needs a render of the scene (surround: rays cast from the camera; sky: the world's L1 light at the
sample's stored normal, from a small Cycles image of the world alone): each sample's scene is rebuilt (a random room
from its seed and the folder's room mode; a ``bake --scenes`` sample from its .blend, camera and frame), probed, and the
sample rewritten with the group added (atomically, the other channels as they were: half stays half), then the
manifest lists the group. A sample that has it already is skipped, so a killed run resumes. Before writing, the
rebuilt scene is checked against the sample: a ray straight ahead must hit at the stored depth of the centre
pixel (within 2 %), else the sample is reported and left as it was (the scene is not the one baked).
Folders being baked must not be filled (the baker rewrites the manifest): stop the bake, ``cli.py merge``, fill.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...model import channels as ch
from ...model.dataset import exrio, folder as ds
from ...model.errors import UserError


def _centre_check(scene, depth: np.ndarray) -> str | None:
    from ..blender.surround import hit_distances
    h, w = depth.shape[:2]
    z = float(depth[h // 2, w // 2, 0]) if depth.ndim == 3 else float(depth[h // 2, w // 2])
    if not (0 < z < 0.99 * scene.camera.data.clip_end):
        return None  # nothing hit there: no check
    # (the centre of an even-sized image lies between pixels: _near_edge forgives a depth edge there)
    got = float(hit_distances(scene, np.array([[0.0, 0.0, -1.0]]))[0])
    if not np.isfinite(got):
        return f"a ray straight ahead hits nothing, the stored centre depth is {z:.3f}"
    if abs(got - z) > 0.02 * z + 1e-3 and not _near_edge(depth):
        return f"a ray straight ahead hits at {got:.3f}, the stored centre depth is {z:.3f}"
    return None


def _near_edge(depth: np.ndarray) -> bool:
    """The centre pixel sits on a depth edge (the exact centre ray may fall on either side)."""
    z = depth[..., 0] if depth.ndim == 3 else depth
    h, w = z.shape
    win = z[h // 2 - 1:h // 2 + 2, w // 2 - 1:w // 2 + 2]
    return float(win.max() / max(win.min(), 1e-6)) > 1.05


FILLABLE = ("surround", "sky")


def add_group(folder, group: str = "surround", log=print) -> dict:
    import bpy

    from ..blender import room, sky, surround
    from ..blender.blendfile import open_blend

    if group not in FILLABLE:
        raise UserError(f"group {group!r} cannot be added to a baked folder; these can: {', '.join(FILLABLE)}")

    folder = Path(folder)
    man_path = folder / ds.MANIFEST
    if not man_path.is_file():
        raise UserError(f"{folder}: no {ds.MANIFEST} (run `cli.py merge {folder}` after a sharded bake)")
    manifest = ds.read_manifest(man_path)
    if any(folder.glob("manifest.shard-*.json")):
        # shard manifests hold samples the merged manifest may not list yet: they would be left unfilled
        listed = set(manifest["samples"])
        extra = sorted({k for p in folder.glob("manifest.shard-*.json")
                        for k in ds.read_manifest(p)["samples"]} - listed)
        if extra:
            raise UserError(f"{folder}: {len(extra)} sample(s) of the shard manifests are not in {ds.MANIFEST} "
                            f"(first {extra[0]}): run `cli.py merge {folder}` first")
    settings = manifest["settings"]
    kind, mode = settings.get("kind", "rooms"), settings.get("room_mode", "diffuse")
    done = skipped = 0
    bad: dict[str, str] = {}
    blend_open = None
    if kind != "scenes":  # the rooms are built into an empty scene, as the baker builds them
        bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for key in sorted(manifest["samples"]):
        meta = manifest["samples"][key]
        path = ds.sample_path(folder, key)
        planes, header = exrio.read_exr(path)
        if all(c in planes for c in ch.GROUPS[group].channels):
            skipped += 1
            continue
        if kind == "scenes":
            if meta["blend"] != blend_open:
                open_blend(meta["blend"])
                blend_open = meta["blend"]
            scene = bpy.data.scenes[meta["scene"]] if meta.get("scene") in bpy.data.scenes else bpy.context.scene
            if meta.get("camera") in bpy.data.objects:
                scene.camera = bpy.data.objects[meta["camera"]]
        else:
            room.build_room(int(meta["seed"]), scene, mode=mode)
        scene.frame_set(int(meta.get("frame", scene.frame_current)))
        depth = np.stack([planes[c] for c in ch.GROUPS["depth"].channels], axis=-1)
        why = _centre_check(scene, depth)
        if why:
            bad[key] = why
            log(f"{path}: not filled: {why}")
            continue
        h, w = depth.shape[:2]
        if group == "surround":
            vals = np.broadcast_to(surround.probe(scene), (h, w, len(ch.SURROUND_COMPONENTS)))
        else:  # the stored normal, camera space, as the baker wrote it
            vals = sky.render_sky(scene, np.stack([planes[c] for c in ch.GROUPS["normal"].channels], axis=-1))
        for i, c in enumerate(ch.GROUPS[group].channels):
            planes[c] = np.ascontiguousarray(vals[..., i], np.float32)
        hdr = {k: v for k, v in header.items() if str(k).startswith("ssgi")}
        exrio.write_exr(path, planes, half=bool(settings.get("half", True)), header=hdr)
        done += 1
        if done % 50 == 0:
            log(f"{folder.name}: {done} filled")
    if not bad:
        groups = ds.stored_groups(manifest) + (group,)
        manifest["channel_spec"] = ch.describe(tuple(dict.fromkeys(groups)))
        ds.write_manifest(folder, manifest)
    return dict(folder=str(folder), filled=done, had_it=skipped, not_filled=bad,
                manifest_lists_it=not bad)
