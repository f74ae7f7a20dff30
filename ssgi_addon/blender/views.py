"""The views of a scene that Fit to Scene bakes, and their roles (train / val / test).

Views: the scene's own cameras at ``len(frames)`` frames spread over the animation (one frame, the current,
when nothing is animated), plus jittered cameras: each a real camera object ``ssgi.fit.view_NN`` sharing the
camera data (lens) of one scene camera and parented to it with a local offset, so that it follows the shot
and every frame gives a new view: moved by up to ``radius`` (JITTER_FRACTION of the diagonal of the scene's
mesh bounds; in a random direction at a random frame of the animation, then shortened so that it passes no
surface there nor at any frame of the plan) and turned by up to JITTER_DEG degrees about the camera's own
axes. The baker renders every camera at every frame, so there are (scene cameras + jittered cameras) x frames
views. Whole jittered cameras are held out: ``val`` cameras choose (best epoch, size, inputs), ``test``
cameras only judge the result. The scene's own cameras are always training views: the point is to fit the
shots the artist renders.

    plan = make_views(scene, views=24, seed=0)        # jittered cameras added to the OPEN file (a copy of it)
    train, val, test = split_views(data_dir, plan)   # held-out views by camera, once baked

A shot (``frames=(A, B)``): ``N_WITHHELD`` whole frames spread over A..B are withheld for the test
(``plan["test_frames"]``: the scene camera there, as the node renders it, is scored after the fit; nothing
at those frames is baked), and every baked frame (``plan["frames"]``, the scene cameras plus jittered ones
near them) lies more than ``GAP`` frames from each withheld frame. The jittered cameras are then train or
val (held out whole, to choose); there are no test cameras.
"""
from __future__ import annotations

import hashlib
import json
import math
import random
from pathlib import Path

from ...model.errors import UserError

JITTER_FRACTION = 0.04  # of the mesh bounds' diagonal
JITTER_DEG = 8.0
VIEW_PREFIX = "ssgi.fit.view_"
N_WITHHELD = 5  # whole frames of a shot withheld for the test
GAP = 1  # no baked view within this many frames of a withheld frame
MIN_SHOT_FRAMES = 4 * N_WITHHELD  # a withheld frame, its two neighbours and a baked frame, N_WITHHELD times


def view_counts(views: int, n_frames_available: int, n_cameras: int) -> tuple[int, int]:
    """(frames, jittered cameras) for about ``views`` views: frames ~ sqrt(views / 2) (at most the animation's
    length), cameras enough for the rest, and at least 3 jittered cameras (one each for val and test)."""
    if views < 4:
        raise UserError(f"--views {views}: at least 4 views are needed (training, validation and test views)")
    nf = max(1, min(n_frames_available, int(round(math.sqrt(views / 2.0)))))
    n_cams = math.ceil(views / nf)
    return nf, max(3, n_cams - n_cameras)


def roles(n_jitter: int, rng: random.Random) -> list[str]:
    """Held-out roles of the jittered cameras: ~20 % val, ~20 % test (at least one each), the rest train."""
    n_val = max(1, round(0.2 * n_jitter))
    n_test = max(1, round(0.2 * n_jitter))
    r = ["val"] * n_val + ["test"] * n_test + ["train"] * (n_jitter - n_val - n_test)
    rng.shuffle(r)
    return r


def _animated(scene) -> bool:
    return any(o.animation_data is not None and o.animation_data.action is not None for o in scene.objects)


def _bounds_diagonal(scene) -> float:
    from mathutils import Vector
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for o in scene.objects:
        if o.type != "MESH" or o.hide_render:
            continue
        for c in o.bound_box:
            w = o.matrix_world @ Vector(c)
            for i in range(3):
                lo[i], hi[i] = min(lo[i], w[i]), max(hi[i], w[i])
    if not math.isfinite(lo[0]):
        return 1.0
    return math.dist(lo, hi)


def _free_offset(scene, depsgraph, origin, offset):
    """``offset`` shortened to half the distance to the first surface along it (the camera stays in free space)."""
    d = offset.length
    if d <= 0:
        return offset
    hit, loc, *_ = scene.ray_cast(depsgraph, origin, offset.normalized(), distance=d * 2.0)
    if hit:
        free = (loc - origin).length
        if free < d * 2.0:
            return offset.normalized() * min(d, 0.5 * free)
    return offset


def withheld_frames(a: int, b: int, n: int = N_WITHHELD) -> list[int]:
    """``n`` frames spread over the shot a..b, at the middles of ``n`` equal parts (none at the ends)."""
    check_shot(a, b)
    return sorted({a + int(math.floor((i + 0.5) * (b - a) / n + 0.5)) for i in range(n)})


def eligible_frames(a: int, b: int, withheld) -> list[int]:
    """The frames of a..b more than ``GAP`` frames from every withheld frame: those the fit may bake."""
    return [f for f in range(a, b + 1) if all(abs(f - w) > GAP for w in withheld)]


def spread(frames: list[int], n: int) -> list[int]:
    """``n`` of ``frames`` (sorted) spread evenly by index, both ends included."""
    if n >= len(frames):
        return list(frames)
    if n <= 1:
        return [frames[len(frames) // 2]]
    return sorted({frames[round(i * (len(frames) - 1) / (n - 1))] for i in range(n)})


def check_shot(a: int, b: int, scene=None) -> None:
    """UserError for a frame range that cannot be fitted as a shot (backwards, outside ``scene``'s range, too
    short to withhold N_WITHHELD frames with baked frames between them)."""
    if b < a:
        raise UserError(f"--frames {a}-{b}: the shot ends before it starts ({b} < {a})")
    if scene is not None and (a < scene.frame_start or b > scene.frame_end):
        raise UserError(f"--frames {a}-{b}: outside scene {scene.name!r}'s frame range "
                        f"{scene.frame_start}-{scene.frame_end}")
    if b - a + 1 < MIN_SHOT_FRAMES:
        raise UserError(f"--frames {a}-{b}: {b - a + 1} frame(s) are too few to withhold {N_WITHHELD} frames for the "
                        f"test with baked frames between them (a shot needs at least {MIN_SHOT_FRAMES})")


def shot_counts(views: int, n_eligible: int, n_cameras: int) -> tuple[int, int]:
    """(baked frames, jittered cameras) of a shot for about ``views`` views: about a third as many frames as
    views (at most the eligible frames), and at least 2 jittered cameras (one val, one train)."""
    if views < 4:
        raise UserError(f"--views {views}: at least 4 views are needed (training and validation views)")
    nf = max(2, min(n_eligible, int(round(views / 3.0))))
    return nf, max(2, math.ceil(views / nf) - n_cameras)


def shot_roles(n_jitter: int, rng: random.Random) -> list[str]:
    """Roles of a shot's jittered cameras: ~25 % val (at least one), the rest train (the test is the withheld
    frames)."""
    n_val = max(1, round(0.25 * n_jitter))
    r = ["val"] * n_val + ["train"] * (n_jitter - n_val)
    rng.shuffle(r)
    return r


def make_views(scene, views: int = 24, seed: int = 0, frames: tuple[int, int] | None = None) -> dict:
    """Add the jittered cameras to ``scene`` (of a file that will be saved as a copy) and return the plan:
    frames, and each camera's role (train / val / test). ``frames=(A, B)``: a shot, with whole frames
    withheld (module doc; ``plan["test_frames"]``, ``plan["test_camera"]``)."""
    from mathutils import Euler, Vector

    cams = [o for o in scene.objects if o.type == "CAMERA"]
    if not cams:
        raise UserError(f"scene {scene.name!r} has no camera: add the camera(s) you render with")
    if scene.camera in cams:  # the active camera first
        cams.remove(scene.camera)
        cams.insert(0, scene.camera)
    rng = random.Random(seed)
    shot = frames is not None
    if shot:
        f0, f1 = int(frames[0]), int(frames[1])
        check_shot(f0, f1, scene)
        withheld = withheld_frames(f0, f1)
        ok = eligible_frames(f0, f1, withheld)
        nf, n_jit = shot_counts(views, len(ok), len(cams))
        frames = spread(ok, nf)
        anim, jitter_roles = True, shot_roles(n_jit, rng)
    else:
        f0, f1 = scene.frame_start, scene.frame_end
        anim = _animated(scene) and f1 > f0
        avail = (f1 - f0 + 1) if anim else 1
        nf, n_jit = view_counts(views, avail, len(cams))
        if anim:
            frames = sorted({f0 + (f1 - f0) * i // max(1, nf - 1) for i in range(nf)}) if nf > 1 else [(f0 + f1) // 2]
        else:
            frames = [scene.frame_current]
        jitter_roles = roles(n_jit, rng)
    radius = JITTER_FRACTION * _bounds_diagonal(scene)
    current = scene.frame_current
    plan = dict(scene=scene.name, frames=frames, radius=radius, max_turn_deg=JITTER_DEG, seed=seed,
                cameras={c.name: "train" for c in cams}, views=views)
    if shot:
        plan.update(shot=[f0, f1], test_frames=withheld, test_camera=cams[0].name, gap=GAP)
    for j, role in enumerate(jitter_roles):
        base = cams[j % len(cams)]
        chosen = (rng.choice(frames) if shot else rng.randint(f0, f1)) if anim else current
        scene.frame_set(chosen)
        m = base.matrix_world.copy()
        direction = Vector([rng.gauss(0, 1) for _ in range(3)])
        if direction.length < 1e-9:
            direction = Vector((1.0, 0.0, 0.0))
        offset = direction.normalized() * radius * rng.uniform(0.4, 1.0)
        turn = Euler((math.radians(rng.uniform(-JITTER_DEG, JITTER_DEG)),
                      math.radians(rng.uniform(-JITTER_DEG, JITTER_DEG)), 0.0), "XYZ").to_matrix().to_4x4()
        # the move in the camera's own frame: the jittered camera follows its base camera (parented), so every
        # frame of the plan gives a new view; the move is shortened so that it passes no surface at the chosen
        # frame nor at any frame the baker renders
        local_t = m.inverted_safe().to_3x3() @ offset
        for f in [chosen] + [f for f in frames if f != chosen]:
            scene.frame_set(f)
            mf = base.matrix_world
            world_t = mf.to_3x3() @ local_t
            free = _free_offset(scene, bpy_context_depsgraph(), mf.to_translation(), world_t)
            if world_t.length > 0 and free.length < world_t.length:
                local_t = local_t * (free.length / world_t.length)
        local = turn.copy()  # turn about the camera's own axes
        local.translation = local_t
        import bpy
        obj = bpy.data.objects.new(f"{VIEW_PREFIX}{j:02d}", base.data)
        scene.collection.objects.link(obj)
        obj.parent = base
        obj.matrix_parent_inverse.identity()
        obj.matrix_basis = local  # world = base's world matrix @ local, at every frame
        obj["ssgi_fit_role"] = role
        obj["ssgi_fit_from"] = base.name
        obj["ssgi_fit_frame"] = chosen
        plan["cameras"][obj.name] = role
    scene.frame_set(current)
    return plan


def bpy_context_depsgraph():
    import bpy
    return bpy.context.evaluated_depsgraph_get()


def default_size(scene, width: int = 240) -> tuple[int, int]:
    """The views' size: ``width`` wide (never wider than the scene renders) at the scene's aspect ratio."""
    r = scene.render
    width = max(8, min(width, int(r.resolution_x * r.resolution_percentage / 100)))
    aspect = (r.resolution_y * r.pixel_aspect_y) / max(1e-9, r.resolution_x * r.pixel_aspect_x)
    return width, max(8, int(round(width * aspect)))


def camera_matrices(scene, camera=None, size=None) -> dict:
    """{"M": the camera's 4x4 world matrix, "P": its 4x4 projection at the render size (or ``size`` (w, h))} at the
    scene's current frame, as lists: what model/infer/lightmap.world_points reads."""
    import numpy as np
    cam = camera or scene.camera
    r = scene.render
    w, h = size or (int(r.resolution_x * r.resolution_percentage / 100), int(r.resolution_y * r.resolution_percentage / 100))
    P = cam.calc_matrix_camera(bpy_context_depsgraph(), x=int(w), y=int(h), scale_x=r.pixel_aspect_x,
                               scale_y=r.pixel_aspect_y)
    return {"M": np.array(cam.matrix_world, dtype=np.float64).tolist(), "P": np.array(P, dtype=np.float64).tolist()}


def view_cameras(scene, data_dir, size) -> dict:
    """{sample key: camera_matrices} of every baked view of ``data_dir`` (its camera at its frame), written to
    ``data_dir/cameras.json`` (the shot lightmap's training reads it); the scene's frame is restored."""
    from ...model import files
    from ...model.dataset import folder
    m = folder.open_folder(data_dir, scenes=True)
    frame0, out = scene.frame_current, {}
    try:
        for key, meta in sorted(m["samples"].items(), key=lambda kv: int(kv[1].get("frame") or frame0)):
            cam = scene.objects.get(sample_camera(meta) or "")
            if cam is None:
                raise UserError(f"{Path(data_dir) / 'manifest.json'}: view {key}'s camera "
                                f"{sample_camera(meta)!r} is not in scene {scene.name!r}")
            scene.frame_set(int(meta.get("frame") or frame0))
            out[key] = camera_matrices(scene, cam, size)
    finally:
        scene.frame_set(frame0)
    files.write_json(Path(data_dir) / "cameras.json", out)
    return out


def sample_camera(meta: dict) -> str | None:
    c = meta.get("camera")
    if isinstance(c, dict):
        c = c.get("name")
    return None if c is None or isinstance(c, (dict, list)) else str(c)


def split_views(data_dir, plan: dict) -> tuple[list[str], list[str], list[str]]:
    """(train, val, test) sample keys of the baked views, by each sample's camera role in the plan."""
    from ...model.dataset import folder
    from ...model.learn import fit as mfit
    m = folder.open_folder(data_dir, scenes=True)
    by_cam: dict[str, list[str]] = {}
    unknown = []
    for key, meta in m["samples"].items():
        cam = sample_camera(meta)
        if cam not in plan["cameras"]:
            unknown.append(key)
            continue
        by_cam.setdefault(cam, []).append(key)
    if unknown:
        raise UserError(f"{Path(data_dir) / 'manifest.json'}: sample(s) {', '.join(unknown[:5])} name no camera of "
                        f"the plan ({', '.join(plan['cameras'])}); bake the views into an empty folder")
    roles_ = plan["cameras"]
    return mfit.split_views(by_cam, test_cameras=[c for c, r in roles_.items() if r == "test"],
                            val_cameras=[c for c, r in roles_.items() if r == "val"])



def derive_plan(data_dir, seed: int = 0) -> dict:
    """Roles for a views folder without a plan: jittered cameras (ssgi.fit.view_*) held out as make_views
    does; when there are none, every camera counts as a view point and the roles are drawn among all."""
    from ...model.dataset import folder
    m = folder.open_folder(data_dir, scenes=True)
    cams = sorted({sample_camera(s) for s in m["samples"].values()} - {None})
    jit = [c for c in cams if c.startswith(VIEW_PREFIX)] or cams
    if len(jit) < 3:
        raise UserError(f"{data_dir}: views of {len(jit)} camera(s); holding out validation and test views needs 3 or more")
    roles_ = dict(zip(jit, roles(len(jit), random.Random(seed))))
    return dict(cameras={c: roles_.get(c, "train") for c in cams}, frames=None, derived=True)


def views_tag(blend: Path, plan: dict) -> str:
    """8 hex digits naming the .blend's bytes and the plan (cameras, frames, size, seed): the same command on
    an unchanged file reuses the views already baked; an edited file gets new views."""
    h = hashlib.sha256()
    with open(blend, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    keys = ("scene", "frames", "cameras", "size", "seed", "radius") + tuple(
        k for k in ("test_frames", "rest_samples", "one_render", "one_render_kind", "proxy_shadows", "proxy_sides")
        if k in plan)  # (so that a plan without them keeps its old tag)
    h.update(json.dumps({k: plan.get(k) for k in keys},
                        sort_keys=True).encode())
    return h.hexdigest()[:8]
