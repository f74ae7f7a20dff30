"""Benchmark: what each view-layer pass SSGI asks for costs one EEVEE render (ray tracing + fast GI
on, the artist scene's own samples), against the same render writing only Combined, in the same run.

    .venv/bin/python benchmarks/pass_flags.py --scenes data/artist_scenes --names cornell_emissive exterior \\
        [--size 960x540] [--repeats 2] [--json out.json]

Each render's wall-clock seconds are printed and kept, and its CPU seconds beside them (``cpu_s``, the JSON's
"cpu_s": steadier on a shared machine).

The scenes are scenes/artist.py's .blend files (``--out`` of that script). Per scene: one untimed warm-up
render at 64x36 with every pass on (Mesa compiles the shaders once), then ``--repeats`` rounds of one render per
configuration in ``CONFIGS`` (Combined only; Combined + one pass; the five passes a one-render model reads; the five +
the motion vectors of the temporal mode), all with ray tracing + fast GI on, ``NO_GI`` (Combined only with both off:
what EEVEE's own GI costs the render) and ``GI_OFF_SETS`` with both off (the passes a GI-off one-render frame would
read), and ``ONE_RENDER_SETS``: the six passes a GI-off one-render frame of a shot with an emitter and a glossy
surface writes, with the emitter proxies (direct_light.emitter_proxies) casting shadows, casting none, or absent
(``one_open_proxies``: unshadowed, only on the sides facing open space, the default).
``--configs`` picks some, in the order given (alternating them round by round); any configuration runs
with ray tracing and fast GI off as NAME_no_gi, and any (either) with EEVEE's shadows off as NAME_no_shadows (what
the shadow pipeline costs: the renders SSGI makes where nothing casts a shadow, ``passes.casts_no_shadow``),
and any (either) as NAME_unculled with EEVEE's light threshold 0 and every lamp a cutoff distance, as SSGI's own
renders make it (``passes.no_light_culled``).
``--filter-size PX``: the film filter of every render (default: the file's; Blender's default is 1.5 px;
most of the passes' cost is the film's filter gather). ``--frame`` / ``--samples``: the frame and the EEVEE samples of
every render (default: frame 1, the file's samples). Prints a yardstick of the machine's speed first
(``machine_speed``, also in the JSON as "machine"), then each render's seconds, the minimum and the median;
machine-noisy, so quote ratios from one run:

    .venv/bin/python benchmarks/pass_flags.py --scenes SHOTS --names cornell_emissive room --frame 25 \
        --configs combined combined_no_gi one_shadowed_proxies_no_gi one_proxies_no_gi one_no_gi --repeats 3
"""
from __future__ import annotations

import argparse
import json
import resource
import sys
import time

import contextlib

import _bootstrap  # noqa: F401,E402  (the checkout as package ssgi)
import bpy  # noqa: E402

from ssgi.model.cliargs import parse_size  # noqa: E402

PASSES = ("use_pass_diffuse_color", "use_pass_diffuse_direct", "use_pass_normal", "use_pass_z", "use_pass_emit")
VECTOR = "use_pass_vector"
# passes a model could read instead (the Glossy Color of the reflection map, Position for normals)
SINGLES = ("use_pass_glossy_color", "use_pass_position")
CONFIGS: dict[str, tuple[str, ...]] = {"combined": (), **{p[len("use_pass_"):]: (p,) for p in PASSES + (VECTOR,) + SINGLES},
                                       "ssgi5": PASSES, "ssgi5+vector": PASSES + (VECTOR,)}
NO_GI = "combined_no_gi"  # Combined only, ray tracing and fast GI off: what EEVEE's own GI costs the render
# A frame that replaces EEVEE's GI with a network needs no ray tracing or fast GI in its one render: every
# configuration above also runs with both off as NAME_no_gi (``combined_no_gi`` is NO_GI), and so do the pass sets a
# GI-off one-render frame could read: colour + diffuse light + the upsampler's normal and depth (ssgi4), colour +
# diffuse light (ssgi2), colour + normal + depth (ssgi3: a model that reads the Combined pass instead of the light).
# ssgi_cz: colour + depth, the normals derived from the depth (passes.render_gbuffer's normals="depth")
GI_OFF_SETS: dict[str, tuple[str, ...]] = {"ssgi4": PASSES[:4], "ssgi2": PASSES[:2],
                                           "ssgi3": (PASSES[0], PASSES[2], PASSES[3]), "ssgi_cz": (PASSES[0], PASSES[3])}
# the GI-off one render of a shot fit (passes.ONE_RENDER_SETTINGS): the five passes + Glossy Color (the
# reflection map's), with the emitter proxies shadowed, unshadowed (the default) or absent:
# {name: (passes, proxies: None = none, else their shadows)}
ONE_PASSES = PASSES + ("use_pass_glossy_color",)
# (the proxies of every side, or only of the sides facing open space,
# direct_light.open_sides, the default; "one_proxies" and "one_shadowed_proxies" keep every side)
ONE_RENDER_SETS: dict[str, tuple[tuple[str, ...], tuple[bool, str] | None]] = {
    "one_shadowed_proxies": (ONE_PASSES, (True, "both")), "one_proxies": (ONE_PASSES, (False, "both")),
    "one_open_proxies": (ONE_PASSES, (False, "open")), "one": (ONE_PASSES, None)}


def optional_pass_flags(view_layer) -> list[str]:
    """The view layer's writable ``use_pass_*`` switches, Combined excepted (Combined is always written)."""
    return [p.identifier for p in view_layer.bl_rna.properties if p.identifier.startswith("use_pass_")
            and p.type == "BOOLEAN" and p.identifier != "use_pass_combined" and not p.is_readonly]


def cpu_s() -> float:
    """CPU seconds of this process so far, all threads: EEVEE's software GL (llvmpipe), the network and the
    compositor run inside it, so the CPU seconds of a render are its work whatever else the machine runs at the
    time, where its wall-clock seconds on this shared 2-core machine scatter by 15-40 %. (Also
    benchmarks/pass_cost.py's.)"""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


UNCULLED = "_unculled"  # suffix: the render with no lamp culled, as SSGI's renders make it (passes.no_light_culled)


@contextlib.contextmanager
def _unculled(scene, on: bool):
    """With ``on``, EEVEE's light threshold 0 and every lamp a cutoff distance (passes.no_light_culled), as every SSGI
    render has them; the file's settings back on exit (passes._settings_kept, which also keeps the EEVEE settings and
    pass flags ``render`` has just set)."""
    from ssgi.ssgi_addon.blender import passes
    if not on:
        yield
        return
    with passes._settings_kept(scene):
        passes.no_light_culled(scene)
        yield


def render(scene, on, gi: bool = True, proxies: tuple[bool, str] | None = None, shadows: bool = True,
           unculled: bool = False) -> tuple[float, float]:
    """(seconds, CPU seconds) of one render with exactly the passes ``on`` besides Combined, ray tracing + fast GI as
    ``gi``, EEVEE's shadows as ``shadows``, with ``proxies`` not None the emitter proxies (their shadows on / off,
    which sides) in the scene during it, and with ``unculled`` no lamp culled (``_unculled``)."""
    from ssgi.ssgi_addon.blender import direct_light
    vl = scene.view_layers[0]
    for f in optional_pass_flags(vl):
        setattr(vl, f, f in on)
    scene.eevee.use_raytracing = scene.eevee.use_fast_gi = gi
    scene.eevee.use_shadows = shadows
    with direct_light.emitter_proxies(scene, *proxies) if proxies is not None else contextlib.nullcontext(), \
            _unculled(scene, unculled):
        t, c = time.perf_counter(), cpu_s()
        bpy.ops.render.render(write_still=False)
        return time.perf_counter() - t, cpu_s() - c


def machine_speed() -> dict:
    """A yardstick of the machine's speed, to tell runs apart (the same benchmark has
    rendered 2.5-3x slower on the same machine kind): the seconds of a pure-Python loop of 10^7 additions (best of 3;
    0.51-0.61 s on the 2-core machine) and the load average."""
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        s = 0
        for i in range(10 ** 7):
            s += i
        best = min(best, time.perf_counter() - t)
    with open("/proc/loadavg") as f:
        load = f.read().split()[:3]
    return {"python_loop_1e7_s": round(best, 3), "loadavg": load}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", required=True, help="folder of scenes/artist.py's .blend files")
    ap.add_argument("--names", nargs="+", default=["cornell_emissive", "exterior"])
    ap.add_argument("--size", type=parse_size, default=(960, 540))
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--frame", type=int, default=1, help="the frame of every scene (default 1)")
    ap.add_argument("--samples", type=int, default=None, help="EEVEE samples of every render (default: the file's)")
    ap.add_argument("--filter-size", type=float, default=None,
                    help="film filter width in px of every render (default: the file's)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--configs", nargs="+", default=None,
                    help=f"only these configurations, in this order each round (default all: "
                         f"{' '.join(CONFIGS)}, each also as NAME_no_gi, and {' '.join(GI_OFF_SETS)} as NAME_no_gi; "
                         f"on request {' '.join(ONE_RENDER_SETS)}, each as NAME_no_gi; any as NAME_no_shadows; any (either) "
                         f"as NAME{UNCULLED}: no lamp culled, as SSGI's renders)")
    a = ap.parse_args(argv)
    # {name: (passes, ray tracing + fast GI, emitter proxies, EEVEE's shadows: True keeps the file's setting)}
    every = {**{k: (on, True, None, True) for k, on in CONFIGS.items()},
             **{f"{k}_no_gi": (on, False, None, True) for k, on in {**CONFIGS, **GI_OFF_SETS}.items()},
             **{f"{k}_no_gi": (on, False, prox, True) for k, (on, prox) in ONE_RENDER_SETS.items()}}
    every |= {f"{k}_no_shadows": (on, gi, prox, False) for k, (on, gi, prox, _s) in every.items()}
    every |= {k + UNCULLED: v for k, v in every.items()}
    for k in a.configs or ():
        if k not in every:
            ap.error(f"--configs: unknown configuration {k!r}; known: {' '.join(every)}")
    chosen = {k: every[k] for k in (a.configs or [*CONFIGS, NO_GI, *(f"{k}_no_gi" for k in GI_OFF_SETS)])}
    res: dict = {"machine": machine_speed(), "filter_size": a.filter_size}
    cpu: dict[str, dict[str, list[float]]] = {}  # {scene: {configuration: CPU seconds of each render}}
    print("machine:", res["machine"], flush=True)
    for name in a.names:
        bpy.ops.wm.open_mainfile(filepath=f"{a.scenes}/{name}.blend")
        sc = bpy.context.scene
        sc.frame_set(a.frame)
        if a.samples:
            sc.eevee.taa_render_samples = a.samples
        sc.render.engine = "BLENDER_EEVEE"
        if a.filter_size is not None:
            sc.render.filter_size = a.filter_size
        own_shadows = sc.eevee.use_shadows  # (the configurations without _no_shadows keep the file's setting)
        sc.render.resolution_percentage = 100
        sc.render.resolution_x, sc.render.resolution_y = 64, 36
        # (untimed: the first render of a pipeline compiles its shaders, 10-30 CPU s at 480x270 on Mesa: GI on,
        # GI off, shadows off)
        render(sc, ONE_PASSES + (VECTOR,), shadows=own_shadows)
        render(sc, ONE_PASSES, gi=False, shadows=own_shadows)
        if not all(sh for *_c, sh in chosen.values()):
            render(sc, ONE_PASSES, gi=False, shadows=False)
        for prox in sorted({p for _o, _g, p, _s in chosen.values() if p is not None}):  # (and with the proxies)
            render(sc, ONE_PASSES, gi=False, proxies=prox, shadows=own_shadows)
        sc.render.resolution_x, sc.render.resolution_y = a.size
        for _ in range(a.repeats):
            for k, (on, gi, prox, shadows) in chosen.items():
                wall, c = render(sc, on, gi=gi, proxies=prox, shadows=own_shadows and shadows,
                                 unculled=k.endswith(UNCULLED))
                res.setdefault(name, {}).setdefault(k, []).append(wall)
                cpu.setdefault(name, {}).setdefault(k, []).append(round(c, 2))
        for k, v in res[name].items():
            c = cpu[name][k]
            print(f"{name} {k:14s} " + " ".join(f"{x:6.2f}" for x in v) + f"  min {min(v):6.2f}"
                  f"  median {sorted(v)[len(v) // 2]:6.2f}   CPU s " + " ".join(f"{x:6.2f}" for x in c)
                  + f"  median {sorted(c)[len(c) // 2]:6.2f}", flush=True)
    res["cpu_s"] = cpu
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
