"""Benchmark: what each render of a whole SSGI frame costs, against EEVEE's own GI render
(ray tracing + fast GI) at the same samples, in the same run.

For each artist scene (scenes/artist.py) at --size, after an untimed warm-up of every render at
64x36 (Mesa compiles the scene's shaders once), it renders
- EEVEE GI: ``report_run.render_eevee_gi`` (ray tracing + fast GI at their defaults, the scene's own world and
  lights) at the scene's samples (16);
- one whole SSGI frame per --variants entry through the render path (``RenderSession``: passes, stand-in
  EXR, prediction, composition, the composite render; nothing written), with ``passes.last_timings`` giving each
  render's seconds: world, direct_soft, emit_direct (Cycles; only with emitters), raster (the direct-only
  G-buffer), rest (the artist-settings render);
and prints a markdown table of seconds per render and the frame / EEVEE GI ratio, in wall-clock seconds and in the
process's CPU seconds (``cpu_s``; the JSON keeps each round's, and each frame's ratio to the EEVEE GI render made just
before it: on a shared machine the paired CPU ratio is the steadiest number, docs/one_render.md).
With --plain-gi in a scene where nothing casts a shadow (passes.casts_no_shadow), whose SSGI renders skip EEVEE's
shadows, the plain EEVEE GI render is also timed with its shadows off (the same image): the frame at equal savings. With --refs (a dataset
folder holding the scenes' Cycles references at this size, e.g. the report's out/reports/artist/data) every
variant's SSGI image is scored (model/metrics.score over the geometry mask of the stored sample, as the report
scores), and the groups of each variant are compared with the first variant's (PSNR, max |difference|).

    nice -n 10 .venv/bin/python benchmarks/pass_cost.py --size 320x180 [--names studio ...] \\
        [--variants before,merged,...] [--refs out/reports/artist/data] [--json out.json] [--repeats 3] [--model M.pt]

With a one-render model (``--model``, docs/one_render.md) every variant makes the same single EEVEE render.
``--blends FILE ... [--frame N]`` times one's own .blend files (a fitted shot's scene) instead of the artist scenes:
    .venv/bin/python benchmarks/pass_cost.py --blends cornell_emissive.blend --frame 25 --size 960x540 \
        --model cornell1r.pt --variants merged --repeats 3 --plain-gi
    nice -n 10 .venv/bin/python benchmarks/pass_cost.py --facts [--refs out/reports/artist/data]

Variants (``VARIANTS``: keywords of passes.render_gbuffer): ``before`` (every group from its own render: the
five-render path), ``merged`` (albedo, normal, depth, emission from the artist-settings render: exact),
``raster1`` (merged + the direct-only render at 1 sample, as the bake renders it), ``rest4`` (raster1 + the
artist-settings render at 4 samples, not the scene's), ``proxy_shadows`` / ``proxy_no_shadows`` (merged, a GI-off
one-render model's emitter proxies with / without shadows, whatever its bake recorded), ``proxy_both_sides`` /
``proxy_open_sides`` (unshadowed proxies on every side of an emitter / only on the sides facing open space). ``--samples N`` renders EEVEE
GI and every frame at N samples instead of the scene's own.
"""
from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
from scenes import artist as A  # noqa: E402
import numpy as np  # noqa: E402

from ssgi.model import metrics  # noqa: E402
from ssgi.model.images import WORLD_DEPTH_FRACTION  # noqa: E402
from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.ssgi_addon.blender import passes  # noqa: E402


def optional_pass_flags(view_layer) -> list[str]:
    """The view layer's writable ``use_pass_*`` switches, Combined excepted (Combined is always written)."""
    return [p.identifier for p in view_layer.bl_rna.properties if p.identifier.startswith("use_pass_")
            and p.type == "BOOLEAN" and p.identifier != "use_pass_combined" and not p.is_readonly]


def cpu_s() -> float:
    """CPU seconds of this process so far, all threads: EEVEE's software GL (llvmpipe), the network and the
    compositor run inside it, so the CPU seconds of a render are its work whatever else the machine runs at the
    time, where its wall-clock seconds on a shared machine scatter by 15-40 %."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

VARIANTS: dict[str, dict] = {
    "before": dict(merge=False),
    "merged": dict(merge=True),
    "raster1": dict(merge=True, raster_samples=1),
    "rest4": dict(merge=True, raster_samples=1, samples=4),  # the artist-settings render at 4 samples too
    # a GI-off one-render model's emitter proxies with / without shadows, whatever the model's bake recorded
    "proxy_shadows": dict(merge=True, proxy_shadows=True),
    "proxy_no_shadows": dict(merge=True, proxy_shadows=False),
    # unshadowed proxies on every side of an emitter, or only on the sides facing open space
    "proxy_both_sides": dict(merge=True, proxy_shadows=False, proxy_sides="both"),
    "proxy_open_sides": dict(merge=True, proxy_shadows=False, proxy_sides="open"),
}
RENDERS = ("world", "direct_soft", "emit_direct", "raster", "rest", "surround", "sky")  # surround: ray casts, no render;
# sky: the world's image (a small Cycles render; kept for the world as it is, so 0 after the warm-up frame)
WARM_SIZE = (64, 36)


def eevee_gi(scene, plain: bool = False, skip_shadows: bool = False) -> tuple[np.ndarray, float, float]:
    """EEVEE GI at the scene's samples: (image, seconds, CPU seconds). ``plain``: with every view-layer pass but
    Combined off (the artist's own render, which writes none of the passes SSGI asks for), put back afterwards.
    ``skip_shadows``: with EEVEE's shadows skipped as SSGI's own renders skip them where nothing casts a shadow
    (passes.casts_no_shadow; the same image), so that the frame is also compared with an EEVEE GI render given the
    same saving."""
    from ssgi.ssgi_addon.pipeline.report_run import render_eevee_gi
    samples = int(scene.eevee.taa_render_samples)
    vl = scene.view_layers[0]
    flags = optional_pass_flags(vl) if plain else []
    saved = {f: getattr(vl, f) for f in flags}
    with passes._settings_kept(scene):
        try:
            for f in flags:
                setattr(vl, f, False)
            t, c = time.perf_counter(), cpu_s()
            img = render_eevee_gi(scene, "default", samples, skip_unused_shadows=skip_shadows)
            return img, time.perf_counter() - t, cpu_s() - c
        finally:
            for f, v in saved.items():
                setattr(vl, f, v)


def ssgi_frame(scene, model, options: dict) -> dict:
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    options = dict(options)
    samples = options.pop("samples", None)
    s = RenderSession(scene, model=model, write=False, keep_groups=True, pass_options=options, samples=samples)
    t, c = time.perf_counter(), cpu_s()
    info = s.run()["per_frame"][0]
    info["t_wall"] = time.perf_counter() - t
    info["cpu_s"] = cpu_s() - c
    res = s.results[0]
    info["groups"], info["prediction"] = res["groups"], res["prediction"]
    return info


def load_refs(folder) -> dict:
    """{scene name: (ref HxWx3, geometry mask)} of a dataset folder baked with --scenes."""
    from ssgi.model import images
    from ssgi.model.dataset import exrio
    folder = Path(folder)
    m = json.loads((folder / "manifest.json").read_text())
    out = {}
    for key, meta in m["samples"].items():
        g = exrio.read_sample(folder / f"{key}.exr", ("ref", "depth", "normal"), strict=False)
        out[meta["scene"]] = (g["ref"][..., :3], images.geometry_mask(g["depth"], g["normal"]))
    return out


def _cmp(a, b) -> dict:
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    d = np.abs(a - b)
    peak = max(float(np.abs(b).max()), 1e-6)
    mse = float((d ** 2).mean())
    return dict(max_abs=float(d.max()), psnr_peak=(math.inf if mse == 0 else 10 * math.log10(peak ** 2 / mse)))


def open_shot(path: str, frame: int):
    """A .blend of one's own (e.g. scenes/shots.py's) at ``frame``, at the warm-up size."""
    import bpy
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    scene.frame_set(int(frame))
    passes.set_resolution(scene, *WARM_SIZE)
    return scene


def run_scene(name, size, variants, model, refs, repeats: int = 1, plain: bool = False, blend=None,
              frame: int = 1, samples: int | None = None) -> dict:
    scene = open_shot(blend, frame) if blend else A.build(name, WARM_SIZE)
    if samples:  # EEVEE GI and the SSGI frame both at these samples (the scene's own by default)
        scene.eevee.taa_render_samples = int(samples)
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    setup_scene(scene, model)
    ssgi_frame(scene, model, VARIANTS["before"])  # warm-up, untimed
    eevee_gi(scene)
    passes.set_resolution(scene, *size)
    row = dict(scene=name, size=f"{size[0]}x{size[1]}", samples=int(scene.eevee.taa_render_samples), variants={})
    # with repeats > 1 EEVEE GI and each variant's frame alternate, and the medians are kept: on a shared machine
    # one render can take twice another's time (docs/one_render.md)
    gi_times, plain_times, gi_cpu, plain_cpu, frames = [], [], [], [], {v: [] for v in variants}
    # where nothing casts a shadow SSGI's renders skip EEVEE's shadows (passes._render): the plain EEVEE GI
    # render is then also timed so, for a comparison at equal savings
    noshadow = plain and passes.casts_no_shadow(scene)
    ns_times, ns_cpu = [], []
    for _ in range(max(1, repeats)):
        img, t, c = eevee_gi(scene)
        gi_times.append(t)
        gi_cpu.append(c)
        if plain:
            _img, t, c = eevee_gi(scene, plain=True)
            plain_times.append(t)
            plain_cpu.append(c)
        if noshadow:
            _img, t, c = eevee_gi(scene, plain=True, skip_shadows=True)
            ns_times.append(t)
            ns_cpu.append(c)
        for v in variants:
            frames[v].append(ssgi_frame(scene, model, VARIANTS[v]))
    row["eevee_gi_s"] = float(np.median(gi_times))
    row["eevee_gi_all_s"] = [round(t, 2) for t in gi_times]
    row["eevee_gi_cpu_s"] = round(float(np.median(gi_cpu)), 2)
    row["eevee_gi_all_cpu_s"] = [round(c, 2) for c in gi_cpu]
    if plain:  # EEVEE GI writing only Combined, as the artist's own render
        row["eevee_gi_plain_s"] = round(float(np.median(plain_times)), 2)
        row["eevee_gi_plain_all_s"] = [round(t, 2) for t in plain_times]
        row["eevee_gi_plain_cpu_s"] = round(float(np.median(plain_cpu)), 2)
        row["eevee_gi_plain_all_cpu_s"] = [round(c, 2) for c in plain_cpu]
    if noshadow:  # the plain EEVEE GI render with its shadows off too (nothing casts one: the same image)
        row["eevee_gi_plain_noshadow_s"] = round(float(np.median(ns_times)), 2)
        row["eevee_gi_plain_noshadow_all_s"] = [round(t, 2) for t in ns_times]
        row["eevee_gi_plain_noshadow_cpu_s"] = round(float(np.median(ns_cpu)), 2)
        row["eevee_gi_plain_noshadow_all_cpu_s"] = [round(c, 2) for c in ns_cpu]
    first = None
    for v in variants:
        runs = sorted(frames[v], key=lambda i: i["t_total"])
        info = runs[len(runs) // 2]
        r = dict(renders={k: round(info["t_pass_renders"].get(k, 0.0), 2) for k in RENDERS},
                 passes_s=round(info["t_passes"], 2), standin_s=round(info["t_standin"], 2),
                 predict_s=round(info["t_predict"], 3), composite_s=round(info["t_composite"], 2),
                 frame_s=round(info["t_total"], 2))
        r["ratio_to_eevee_gi"] = round(info["t_total"] / row["eevee_gi_s"], 2)
        r["frame_all_s"] = [round(i["t_total"], 2) for i in frames[v]]
        # each frame against the EEVEE GI render made just before it
        r["paired_ratios"] = [round(i["t_total"] / t, 3) for i, t in zip(frames[v], gi_times)]
        # the same in CPU seconds (cpu_s): medians, and each frame against the EEVEE GI render made just before it
        cpus = [i["cpu_s"] for i in frames[v]]
        r["frame_cpu_s"] = round(float(np.median(cpus)), 2)
        r["frame_all_cpu_s"] = [round(c, 2) for c in cpus]
        r["cpu_ratio_to_eevee_gi"] = round(r["frame_cpu_s"] / row["eevee_gi_cpu_s"], 3)
        r["paired_cpu_ratios"] = [round(c / g, 3) for c, g in zip(cpus, gi_cpu)]
        if plain:
            r["ratio_to_eevee_gi_plain"] = round(info["t_total"] / row["eevee_gi_plain_s"], 2)
            r["cpu_ratio_to_eevee_gi_plain"] = round(r["frame_cpu_s"] / row["eevee_gi_plain_cpu_s"], 3)
            r["paired_cpu_ratios_plain"] = [round(c / g, 3) for c, g in zip(cpus, plain_cpu)]
        r["shadows_skipped"] = bool(info.get("shadows_skipped"))
        r["emission_skipped"] = bool(info.get("emission_skipped"))
        r["normals_from_depth"] = bool(info.get("normals_from_depth"))
        if noshadow:
            r["ratio_to_eevee_gi_plain_noshadow"] = round(info["t_total"] / row["eevee_gi_plain_noshadow_s"], 2)
            r["cpu_ratio_to_eevee_gi_plain_noshadow"] = round(r["frame_cpu_s"] / row["eevee_gi_plain_noshadow_cpu_s"], 3)
            r["paired_cpu_ratios_plain_noshadow"] = [round(c / g, 3) for c, g in zip(cpus, ns_cpu)]
        if name in refs:
            ref, mask = refs[name]
            sc = metrics.score(info["prediction"], ref, mask)
            r["score"] = {k: round(float(sc[k]), 3) for k in ("psnr", "ssim", "flip")}
        groups = {g: a for g, a in info["groups"].items() if g != "beauty"} | {"image": info["prediction"]}
        if first is None:
            first = groups
        else:
            r["vs_first"] = {g: {k: round(x, 4) if math.isfinite(x) else "inf" for k, x in _cmp(groups[g], first[g]).items()}
                             for g in groups if g in first}
        row["variants"][v] = r
        print(f"{name} {v}: frame {r['frame_s']} s ({r['ratio_to_eevee_gi']}x EEVEE GI {row['eevee_gi_s']:.2f} s; "
              f"CPU {r['frame_cpu_s']} s, {r['cpu_ratio_to_eevee_gi']}x"
              + (f", {r['cpu_ratio_to_eevee_gi_plain']}x plain" if plain else "")
              + (f", {r['cpu_ratio_to_eevee_gi_plain_noshadow']}x plain with its shadows off too" if noshadow else "")
              + f") {r['renders']} {r.get('score', '')}", file=sys.stderr, flush=True)
        # the number to read on a shared machine: each round's frame against the render made just before it
        for key, what in (("paired_cpu_ratios_plain", "plain EEVEE GI"),
                          ("paired_cpu_ratios_plain_noshadow", "plain EEVEE GI with its shadows off too")):
            if key in r:
                p = r[key]
                print(f"{name} {v}: frame / {what}, CPU s, paired over {len(p)} rounds: median "
                      f"{float(np.median(p)):.3f} ({min(p):.3f}-{max(p):.3f})", file=sys.stderr, flush=True)
    row["eevee_gi_s"] = round(row["eevee_gi_s"], 2)
    if name in refs:
        ref, mask = refs[name]
        row["eevee_gi_score"] = {k: round(float(v), 3) for k, v in metrics.score(img, ref, mask).items()
                                 if k in ("psnr", "ssim", "flip")}
    return row


def facts(size=(96, 54)) -> dict:
    """What Blender allows, measured on the tiny scene (a lamp, an emissive panel, metal, glass) under a gradient
    sky: whether EEVEE writes light-group passes, what the Environment pass holds against the ``world`` group,
    and how far the SHARED_GROUPS of the artist-settings render are from the direct-only render's."""
    scene = _bootstrap.empty_scene()
    A.tiny_material_scene(scene)
    A.world_gradient(scene, (0.1, 0.09, 0.08), (0.6, 0.7, 0.8), (0.2, 0.35, 0.8), strength=1.0)
    passes.set_resolution(scene, *size)
    vl = scene.view_layers[0]
    out = {}
    with passes._settings_kept(scene):  # light groups: lamps + emitter in one, the world in another
        vl.lightgroups.add(name="lamps")
        vl.lightgroups.add(name="sky")
        for o in scene.objects:
            if o.type == "LIGHT" or "emissive" in o.name:
                o.lightgroup = "lamps"
        scene.world.lightgroup = "sky"
        vl.use_pass_environment = vl.use_pass_diffuse_direct = vl.use_pass_diffuse_color = True
        scene.eevee.use_raytracing = scene.eevee.use_fast_gi = False
        scene.eevee.taa_render_samples = 1
        p = passes._render(scene)
        out["eevee_passes_with_light_groups"] = sorted(p)
        vl.use_pass_environment = False
    g = passes.render_gbuffer(scene, ("albedo", "normal", "depth", "emission", "world", "rest"), samples=2,
                              rest_samples=2, merge=False)
    with passes._settings_kept(scene):
        vl.use_pass_environment = True
        scene.eevee.taa_render_samples = 2
        env = passes._rgb(passes._render(scene), "Environment")
    geo = g["depth"][..., 0] < WORLD_DEPTH_FRACTION * scene.camera.data.clip_end
    out["environment_mean_on_geometry"] = float(env[geo].mean())
    out["environment_mean_on_sky"] = float(env[~geo].mean())
    out["world_group_mean_on_geometry"] = float(g["world"][geo].mean())
    m = passes.render_gbuffer(scene, ("albedo", "normal", "depth", "emission", "rest"), samples=2, rest_samples=2)
    out["shared_max_abs"] = {k: float(np.abs(m[k] - g[k]).max()) for k in passes.SHARED_GROUPS}
    return out


def world_linearity(folder) -> dict:
    """How far each stored ``world`` group is from a linear function of the normal (spherical harmonics L1):
    per scene, the mean and the RMS residual of a least-squares fit over the geometry pixels."""
    from ssgi.model import images
    from ssgi.model.dataset import exrio
    folder = Path(folder)
    m = json.loads((folder / "manifest.json").read_text())
    out = {}
    for key, meta in m["samples"].items():
        g = exrio.read_sample(folder / f"{key}.exr", ("world", "normal", "depth"), strict=False)
        mask = images.geometry_mask(g["depth"], g["normal"])
        w = g.get("world")
        if w is None or not mask.any() or w[mask].max() <= 0:
            continue
        x = np.concatenate([np.ones((int(mask.sum()), 1)), g["normal"][mask]], 1)
        coef, *_ = np.linalg.lstsq(x, w[mask][:, :3], rcond=None)
        r = x @ coef - w[mask][:, :3]
        out[meta["scene"]] = dict(mean=round(float(w[mask].mean()), 4), rms_residual=round(float(np.sqrt((r ** 2).mean())), 5))
    return out


def table(rows, variants) -> str:
    head = ("| scene | size | variant | " + " | ".join(RENDERS) + " | stand-in + predict + composite | whole frame "
            "| EEVEE GI | frame / GI | frame / GI, CPU s | frame / plain GI, CPU s | PSNR |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for row in rows:
        for v in variants:
            r = row["variants"][v]
            rest = r["standin_s"] + r["predict_s"] + r["composite_s"]
            ps = r.get("score", {}).get("psnr")
            lines.append(f"| {row['scene']} | {row['size']} | {v} | " + " | ".join(
                f"{r['renders'][k]:.2f}" if r["renders"][k] else "-" for k in RENDERS)
                + f" | {rest:.2f} | {r['frame_s']:.2f} | {row['eevee_gi_s']:.2f} | {r['ratio_to_eevee_gi']:.2f} | "
                + f"{r['cpu_ratio_to_eevee_gi']:.3f} | " + (f"{r['cpu_ratio_to_eevee_gi_plain']:.3f}"
                                                           if "cpu_ratio_to_eevee_gi_plain" in r else "-") + " | "
                + (f"{ps:.2f}" if ps is not None else "") + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--names", nargs="+", default=list(A.NAMES), choices=A.NAMES)
    ap.add_argument("--size", type=parse_size, default=A.DEFAULT_SIZE)
    ap.add_argument("--variants", default="before,merged", help=f"comma-separated, of {', '.join(VARIANTS)}")
    ap.add_argument("--blends", nargs="+", default=None, metavar="FILE.blend",
                    help="time these .blend files (at --frame) instead of the artist scenes --names")
    ap.add_argument("--frame", type=int, default=1, help="the frame of --blends (default 1)")
    ap.add_argument("--model", default=None, help="checkpoint (default: the shipped model)")
    ap.add_argument("--refs", default=None, help="dataset folder with the scenes' Cycles references at --size")
    ap.add_argument("--json", default=None, help="write the rows here")
    ap.add_argument("--plain-gi", action="store_true", help="also time EEVEE GI with only the Combined pass "
                    "written (the artist's own render writes none of SSGI's passes)")
    ap.add_argument("--samples", type=int, default=None, help="render EEVEE GI and the SSGI frames at this many "
                    "samples (default: each scene's own)")
    ap.add_argument("--repeats", type=int, default=1, help="EEVEE GI and each frame this many times, alternating; "
                    "the medians are reported (default 1)")
    ap.add_argument("--facts", action="store_true", help="only measure what Blender allows (light groups, the "
                    "Environment pass, the shared groups; with --refs the world group's linearity) and exit")
    a = ap.parse_args(argv)
    if a.facts:
        res = facts() | ({"world_vs_normal_L1": world_linearity(a.refs)} if a.refs else {})
        print(json.dumps(res, indent=1))
        return 0
    variants = [v.strip() for v in a.variants.split(",") if v.strip()]
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        ap.error(f"--variants: unknown {', '.join(bad)}; known: {', '.join(VARIANTS)}")
    refs = load_refs(a.refs) if a.refs else {}
    up = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"load before: {up}", file=sys.stderr)
    rows = []
    todo = [(Path(b).stem, b) for b in a.blends] if a.blends else [(n, None) for n in a.names]
    for n, blend in todo:  # the JSON is rewritten after each scene: a stopped run keeps the scenes done
        rows.append(run_scene(n, a.size, variants, a.model, refs, a.repeats, a.plain_gi, blend=blend, frame=a.frame,
                              samples=a.samples))
        if a.json:
            Path(a.json).write_text(json.dumps(dict(rows=rows, load_before=up), indent=1))
    up2 = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(table(rows, variants))
    print(f"\nload before: {up}\nload after: {up2}")
    if a.json:
        Path(a.json).write_text(json.dumps(dict(rows=rows, load_before=up, load_after=up2), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
