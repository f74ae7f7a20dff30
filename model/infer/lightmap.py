"""A shot's lightmap: a small world-space field of diffuse light, fitted to one scene's views (bpy-free, numpy).

The shot fit (`cli.py fit --frames`) learns a screen-space network from views of one scene. Its errors on
frames it never saw are smooth biases over large surfaces (a wall a little too bright, docs/fit.md), because a
screen-space network only knows what the frame shows. Every view of a shot looks at the same walls, though: the
diffuse light on a static surface is a function of where the surface is and which way it faces. The lightmap is
that function, learned from the views (model/learn/lightmap.py): an MLP of the world position (Fourier features,
``NFREQ`` octaves over the views' bounding box) and the world normal, giving the diffuse light (the target divided
by the albedo). At render time:

1. ``world_points(depth, normal, M, P)``: each pixel's world position and world normal, from the EEVEE depth
   (distance along the view axis) and camera-space normals, with the camera's world matrix ``M`` and its projection
   ``P`` (Blender's ``Object.calc_matrix_camera`` at the render size; perspective or orthographic);
2. ``Lightmap.light(...)``: the MLP's diffuse light at those points (at a large output, at the working
   resolution's representative pixels and upsampled with the depth/normal-guided upsampler of workres.py);
3. ``Lightmap.apply(part, groups, M, P)``: the network's diffuse part blended with albedo x that light, with weight
   ``lam`` where the blend is safe and 0 elsewhere: pixels with a (near-)black albedo channel (metal, emitters) and
   pixels where nothing was hit. ``lam`` is chosen by the fit on its validation views; 0 means the lightmap is not
   used. The lightmap is blended on the ``edges`` too (the two pixels of a depth discontinuity or crease, or a
   3 x 3 neighbourhood where the normal or the albedo changes: anti-aliased silhouettes and textures, where one
   light per pixel is wrong): keeping the network there cost every shot fit's withheld frames 0.9-4.8 dB
   (the network's own light on every edge and every texture: bright lines along a room's corners, a checker
   armchair left to the network); ``blend_weight(network_on_edges=True)`` keeps that rule for comparison.

**Known light** (``known``): a field can instead learn the light *minus* the frame's own direct light,
passes the render path renders anyway (``direct_soft`` or ``direct``, ``emit_direct``: ``KNOWN_CANDIDATES``); at render
time it adds them back, ``light = max(sum of the known groups + field, 0)``. Direct light, with its shadows, then
comes from each frame's own rasterized passes, so a moving object's shadow moves with it, and the field holds only
the indirect rest, which changes little over a shot. Which way a shot takes is chosen by the fit on its validation
views (model/learn/lightmap.py). What it still cannot know: a moving object's indirect light (bounce, occlusion of
indirect light) at a place it was not baked, and indirect light that changes over the shot (lamps switched on); the
screen-space network still renders those, and ``lam`` < 1 keeps part of it everywhere.
The file lives beside the model (``path_for``: ``shot.pt`` -> ``shot.lightmap.npz``, also found from
``shot.onnx``), numpy only, so the ONNX path without torch uses it too.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import channels as ch
from ..errors import UserError
from ..images import camera_points

NFREQ = 6  # Fourier octaves of the position (pi * 2**i, i < NFREQ, over [-1, 1])
ALBEDO_MIN = 0.02  # a pixel is blended only where every albedo channel exceeds this
EDGE_DEPTH = 0.02  # second difference of 1/depth, relative to 1/depth, that marks a depth edge (``edges``)
EDGE_NORMAL = 0.1  # ... of any normal component
EDGE_LOG_ALBEDO = 0.1  # ... of any channel's log albedo (texture, colour edges)
MAX_FULL_PIXELS = 600_000  # larger outputs evaluate the field at the working resolution's factor
FORMAT = 1
KEYS = ("lo", "hi", "nfreq", "lam", "format")
# the frame's own direct light a field may learn beside (at most one of the first two: both hold the lamps' direct
# light, the soft one with the lamps' real size); the fit keeps those the model's own inputs already include
KNOWN_CANDIDATES = (("direct_soft", "direct"), ("emit_direct",))


def known_for(groups) -> tuple[str, ...]:
    """The known-light groups a field can use when a frame renders ``groups`` (``KNOWN_CANDIDATES``)."""
    have = set(groups)
    out = []
    for alternatives in KNOWN_CANDIDATES:
        pick = [g for g in alternatives if g in have][:1]
        out += pick
    return tuple(out)


def known_light(groups: dict, known) -> np.ndarray | float:
    """The sum of a frame's ``known`` groups (HxWx3), or 0.0 when there are none."""
    if not known:
        return 0.0
    missing = [k for k in known if k not in groups]
    if missing:
        raise UserError(f"lightmap: the frame has no {', '.join(missing)} pass, which its field adds back")
    return sum(np.nan_to_num(np.asarray(groups[k], np.float32)[..., :3]) for k in known)


def path_for(model_path) -> Path:
    """The lightmap file of a model: beside it, the model's stem + ``.lightmap.npz``."""
    p = Path(model_path)
    return p.with_name(p.stem + ".lightmap.npz")


# --- geometry ------------------------------------------------------------------------------------------

def world_points(depth: np.ndarray, normal: np.ndarray, M, P, pixels=None) -> tuple[np.ndarray, np.ndarray]:
    """(HxWx3 world positions, HxWx3 world normals) of a frame: ``depth`` HxW or HxWx1 (distance along the view
    axis, top row first), ``normal`` HxWx3 in camera space, ``M`` the camera's 4x4 world matrix, ``P`` its 4x4
    projection (OpenGL convention, Blender's calc_matrix_camera). ``pixels``: (columns, rows, W, H) when ``depth``
    and ``normal`` are samples of a W x H frame at those pixels (arrays shaped like ``depth``), not the frame."""
    z = np.asarray(depth, np.float64)
    z = z[..., 0] if z.ndim == 3 else z
    M, P = np.asarray(M, np.float64), np.asarray(P, np.float64)
    if pixels is None:
        H, W = z.shape
        nx = (np.arange(W) + 0.5) / W * 2.0 - 1.0
        ny = 1.0 - (np.arange(H) + 0.5) / H * 2.0
        nx, ny = np.meshgrid(nx, ny)
    else:
        cols, rows, W, H = pixels
        nx = (np.asarray(cols, np.float64) + 0.5) / W * 2.0 - 1.0
        ny = 1.0 - (np.asarray(rows, np.float64) + 0.5) / H * 2.0
    pc = camera_points(z, nx, ny, P)
    pw = pc @ M[:3, :3].T + M[:3, 3]
    R = M[:3, :3] / np.linalg.norm(M[:3, :3], axis=0, keepdims=True)  # the camera's scale does not turn normals
    nw = np.asarray(normal, np.float64)[..., :3] @ R.T
    return pw.astype(np.float32), nw.astype(np.float32)


def project(points: np.ndarray, M, P, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(column, row, depth) of world points in a camera: the inverse of ``world_points`` (pixel centres at
    integers, depth along the view axis)."""
    M, P = np.asarray(M, np.float64), np.asarray(P, np.float64)
    pc = (np.asarray(points, np.float64) - M[:3, 3]) @ np.linalg.inv(M[:3, :3]).T
    clip = np.concatenate([pc, np.ones(pc.shape[:-1] + (1,))], -1) @ P.T
    ndc = clip[..., :2] / clip[..., 3:4]
    return (ndc[..., 0] + 1) / 2 * width - 0.5, (1 - ndc[..., 1]) / 2 * height - 0.5, -pc[..., 2]


def edges(depth: np.ndarray, normal: np.ndarray, albedo: np.ndarray, normals: bool = True) -> np.ndarray:
    """HxW bool: pixels beside a depth discontinuity or crease (second difference of 1/depth), or whose 3 x 3
    neighbourhood changes normal (unless not ``normals``: a small sphere's normals change that fast everywhere)
    or albedo (module doc)."""
    def spread(a):  # 3 x 3 max - min, edge pixels repeated, separably (numpy only: the extension ships no scipy)
        ap = np.pad(a, 1, mode="edge")
        hi = np.maximum(np.maximum(ap[:, :-2], ap[:, 1:-1]), ap[:, 2:])
        lo = np.minimum(np.minimum(ap[:, :-2], ap[:, 1:-1]), ap[:, 2:])
        return (np.maximum(np.maximum(hi[:-2], hi[1:-1]), hi[2:])
                - np.minimum(np.minimum(lo[:-2], lo[1:-1]), lo[2:]))

    z = np.asarray(depth, np.float32)
    z = z[..., 0] if z.ndim == 3 else z
    # depth: 1/z is linear across the screen on a plane, so its second difference (relative to 1/z) is ~0 on any
    # flat face, however grazing, and large at a silhouette or a crease; a jump between two pixels gives a large
    # second difference at both (the two pixels an anti-aliased edge mixes), so no further spread (a
    # 3 x 3 spread kept 4-pixel bands from the lightmap, -0.05 to -0.23 dB on the withheld frames)
    iz = 1.0 / np.maximum(np.nan_to_num(z, nan=1e30, posinf=1e30), 1e-3)
    ip = np.pad(iz, 1, mode="edge")
    d2 = np.maximum(np.abs(ip[1:-1, :-2] + ip[1:-1, 2:] - 2 * iz), np.abs(ip[:-2, 1:-1] + ip[2:, 1:-1] - 2 * iz))
    e = d2 > EDGE_DEPTH * iz
    n = np.nan_to_num(np.asarray(normal, np.float32))
    a = np.log(np.maximum(np.nan_to_num(np.asarray(albedo, np.float32)), 1e-3))
    for c in range(3):
        if normals:
            e |= spread(n[..., c]) > EDGE_NORMAL
        e |= spread(a[..., c]) > EDGE_LOG_ALBEDO
    return e


def blend_weight(groups: dict, lam: float, network_on_edges: bool = False) -> np.ndarray:
    """HxW float32: where and how much the lightmap replaces the network (module doc). ``network_on_edges``: not on
    ``edges`` either (for comparison: that rule costs every shot fit 0.9-4.8 dB)."""
    from ..images import geometry_mask
    alb = np.asarray(groups["albedo"], np.float32)[..., :3]
    ok = geometry_mask(groups["depth"], groups["normal"]) & (alb > ALBEDO_MIN).all(-1)
    if network_on_edges:
        ok &= ~edges(groups["depth"], groups["normal"], alb)
    return (float(lam) * ok).astype(np.float32)


# --- the field -----------------------------------------------------------------------------------------

def encode(points: np.ndarray, normals: np.ndarray, lo, hi, nfreq: int, nfreq_dir: int = 0) -> np.ndarray:
    """Nx(6 + 6 nfreq + 6 nfreq_dir) features: the position scaled to [-1, 1] over the box lo..hi, the normal (a
    reflection map's reflected direction), sin/cos of the scaled position at nfreq octaves and of the normal at
    nfreq_dir octaves. The same in the trainer (torch, model/learn/lightmap._Field) and here."""
    lo, hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
    p = (np.asarray(points, np.float32) - lo) / np.maximum(hi - lo, 1e-6) * 2.0 - 1.0
    d = np.asarray(normals, np.float32)
    fs = [p, d]
    for x, octaves in ((p, nfreq), (d, nfreq_dir)):
        for i in range(int(octaves)):
            w = np.float32(np.pi * 2 ** i)
            fs += [np.sin(x * w), np.cos(x * w)]
    return np.concatenate(fs, -1)


def mlp(h: np.ndarray, weights) -> np.ndarray:
    """An MLP's output for features ``h`` (NxD): ``weights`` [(W, b), ...], ReLU between layers (numpy)."""
    for i, (w, b) in enumerate(weights):
        h = h @ w.T + b
        if i < len(weights) - 1:
            np.maximum(h, 0.0, out=h)
    return h


def save_field(path, weights, meta: dict, **arrays) -> Path:
    """Write an MLP field's file (a shot's lightmap or reflection map) atomically: its layers, ``arrays`` and
    ``meta`` (JSON)."""
    import json

    from .. import files
    out = {f"w{i}": w for i, (w, _) in enumerate(weights)}
    out.update({f"b{i}": b for i, (_, b) in enumerate(weights)})
    out.update(arrays, meta=np.array(json.dumps(meta, default=str)))

    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez(fh, **out)
    return files.atomic_write(Path(path), write)


def load_field(path, keys, fmt: int, what: str) -> tuple[list, dict, dict]:
    """(layers, {key: array}, meta) of an MLP field's file; UserError naming the file when it is not one of
    ``what`` (missing ``keys``, another ``format``) or cannot be read."""
    import json
    import zipfile
    try:
        with np.load(Path(path), allow_pickle=False) as z:
            missing = [k for k in keys if k not in z.files]
            if missing:
                raise UserError(f"{path}: not an SSGI {what} (no {', '.join(missing)})")
            if int(z["format"]) != fmt:
                raise UserError(f"{path}: {what} format {int(z['format'])}, this SSGI reads {fmt}")
            n = sum(1 for k in z.files if k.startswith("w"))
            weights = [(z[f"w{i}"], z[f"b{i}"]) for i in range(n)]
            meta = json.loads(str(z["meta"])) if "meta" in z.files else {}
            return weights, {k: z[k] for k in z.files if not k.startswith(("w", "b")) and k != "meta"}, meta
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as e:
        raise UserError(f"{path}: cannot read the {what} ({type(e).__name__}: {e})") from None


class Lightmap:
    """The fitted field: ``weights`` [(W, b), ...] of an MLP with ReLU between layers (numpy), the box ``lo``/``hi``,
    ``nfreq``, the blend weight ``lam`` and the ``known`` groups it adds back (module doc)."""

    def __init__(self, weights, lo, hi, nfreq: int = NFREQ, lam: float = 0.0, meta: dict | None = None,
                 known=(), signed: bool | None = None):
        self.known = tuple(known)  # groups added back at render time (module doc); () = the field is the light
        # a ref_combined model's field: the light its prediction adds to EEVEE's GI-off image, signed (recorded as
        # the meta's target when saved)
        self.signed = bool(signed) if signed is not None else ch.signed_part(dict(meta or {}).get("target") or ch.TARGET_GROUP)
        bad = [k for k in self.known if not any(k in alt for alt in KNOWN_CANDIDATES)]
        if bad:
            raise UserError(f"lightmap: unknown known-light group(s) {', '.join(bad)}")
        self.weights = [(np.asarray(w, np.float32), np.asarray(b, np.float32)) for w, b in weights]
        self.lo, self.hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
        self.nfreq, self.lam = int(nfreq), float(lam)
        self.meta = dict(meta or {})
        din = 6 + 6 * self.nfreq
        if not self.weights or self.weights[0][0].shape[1] != din or self.weights[-1][0].shape[0] != 3:
            raise UserError(f"lightmap: layers {[w.shape for w, _ in self.weights]} do not map {din} features to RGB")

    def field(self, points: np.ndarray, normals: np.ndarray, chunk: int = 65536) -> np.ndarray:
        """Nx3 field values at N world points facing ``normals``: the diffuse light (>= 0), or with ``known`` the
        light minus the known groups (signed)."""
        pts, nrm = np.reshape(points, (-1, 3)), np.reshape(normals, (-1, 3))
        out = np.empty((len(pts), 3), np.float32)
        for s in range(0, len(pts), chunk):
            out[s:s + chunk] = mlp(encode(pts[s:s + chunk], nrm[s:s + chunk], self.lo, self.hi, self.nfreq),
                                   self.weights)
        out = np.nan_to_num(out, nan=0.0, posinf=0.0, neginf=0.0)
        return out if (self.known or self.signed) else np.maximum(out, 0.0)

    def light(self, groups: dict, M, P, factor: int | None = None) -> np.ndarray:
        """HxWx3 diffuse light of the frame's pixels (module doc, step 2). ``factor``: evaluate at the working
        resolution's representative pixels and upsample (None: every pixel up to MAX_FULL_PIXELS)."""
        from . import workres
        z = np.asarray(groups["depth"], np.float32)
        z = z if z.ndim == 3 else z[..., None]
        H, W = z.shape[:2]
        f = int(factor) if factor else max(1, int(np.ceil(np.sqrt(H * W / MAX_FULL_PIXELS))))
        known = known_light(groups, self.known)
        if f == 1:
            pw, nw = world_points(z, groups["normal"], M, P)
            return self._total(self.field(pw, nw).reshape(H, W, 3) + known)
        # only the representative pixels are placed in the world (their own pixel centres), then upsampled
        idx = workres.representative_index(z[..., 0], f)
        n = np.asarray(groups["normal"], np.float32)
        lo = {"depth": workres.pick(z, f, idx), "normal": workres.pick(n, f, idx)}
        h, w = idx.shape
        by, bx = np.divmod(idx, f)
        rows = np.minimum(np.arange(h)[:, None] * f + by, H - 1)  # border blocks repeat the edge pixels (pick)
        cols = np.minimum(np.arange(w)[None, :] * f + bx, W - 1)
        pts, nrm = world_points(lo["depth"], lo["normal"], M, P, pixels=(cols, rows, W, H))
        light_lo = self.field(pts, nrm).reshape(pts.shape)
        hi = {"depth": z, "normal": n}
        return self._total(workres.upsample_light(light_lo, lo, hi, factor=f) + known)

    def _total(self, light: np.ndarray) -> np.ndarray:
        """The light the frame gets: >= 0, except a signed field's (the light a ref_combined model adds to EEVEE's
        image, which takes light away where EEVEE's image is too bright: the unshadowed emitter proxies' light)."""
        return np.asarray(light, np.float32) if self.signed else np.maximum(light, 0.0)

    def apply(self, part: np.ndarray, groups: dict, M, P, factor: int | None = None) -> np.ndarray:
        """The network's diffuse ``part`` (HxWx3) blended with albedo x the lightmap's light (module doc, step 3).
        ``lam`` 0 returns ``part`` itself."""
        if self.lam <= 0.0:
            return part
        w = blend_weight(groups, self.lam)[..., None]
        if not w.any():
            return part
        lm = np.asarray(groups["albedo"], np.float32)[..., :3] * self.light(groups, M, P, factor)
        return (w * lm + (1.0 - w) * np.asarray(part, np.float32)).astype(np.float32)

    # --- the file ---

    def save(self, path) -> Path:
        return save_field(path, self.weights, self.meta, lo=self.lo, hi=self.hi, nfreq=np.int64(self.nfreq),
                          lam=np.float64(self.lam), format=np.int64(FORMAT), known=np.array("+".join(self.known)))

    @classmethod
    def load(cls, path) -> "Lightmap":
        weights, z, meta = load_field(path, KEYS, FORMAT, "lightmap")
        try:
            known = tuple(k for k in str(z["known"]).split("+") if k) if "known" in z else ()
            return cls(weights, z["lo"], z["hi"], int(z["nfreq"]), float(z["lam"]), meta, known)
        except (ValueError, TypeError) as e:
            raise UserError(f"{path}: cannot read the lightmap ({type(e).__name__}: {e})") from None


def load_beside(model_path) -> Lightmap | None:
    """The model's lightmap when there is one beside it (``path_for``) and it is used (lam > 0), else None."""
    p = path_for(model_path)
    if not p.is_file():
        return None
    lm = Lightmap.load(p)
    return lm if lm.lam > 0.0 else None
