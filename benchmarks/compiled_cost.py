"""Benchmark: what a compiled SSGI frame (docs/compiled.md) costs against EEVEE's own GI render, paired in one run.

For each artist scene (scenes/artist.py) at --size and --samples, it saves the scene as the artist has it (EEVEE with
ray tracing + fast GI) and a copy set up by ``cli.py setup --compiled`` (pipeline/setup.py), then, in alternating
child processes (plain bpy: the copy's render imports nothing of the extension), times after one untimed warm-up:
- ``eevee_gi``: a plain render of the artist's file (``bpy.ops.render.render()``);
- ``compiled``: a plain render of the compiled copy (its one GI-off render + the compiled group);
- ``compiled_no_group``: the same copy with the compositor off (the one render alone);
- ``group_only``: the compiled group alone, fed float images of the render's size (Render Layers muted: no 3D render).
Prints one JSON line per scene: median wall and CPU seconds of each, and the compiled / EEVEE GI ratios.

    nice -n 5 .venv/bin/python benchmarks/compiled_cost.py --model M.pt --size 960x540 [--samples 16] \\
        [--names living_room cornell_emissive] [--repeats 2] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package ssgi)

TIMER = '''
import json, resource, sys, time, bpy
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
sc = bpy.context.scene
sc.render.use_compositing = sys.argv[2] != "off"
if sys.argv[2] == "group":  # the group alone: Render Layers muted (no 3D render), its passes from float images
    import numpy as np
    tree = sc.compositing_node_group
    rl = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers")
    w = sc.render.resolution_x * sc.render.resolution_percentage // 100
    h = sc.render.resolution_y * sc.render.resolution_percentage // 100
    rng = np.random.default_rng(0)
    for link in [l for l in tree.links if l.from_node == rl]:
        img = bpy.data.images.new(link.from_socket.name, w, h, float_buffer=True)
        img.pixels.foreach_set(rng.random(w * h * 4, dtype=np.float32))
        node = tree.nodes.new("CompositorNodeImage")
        node.image = img
        tree.links.new(node.outputs[0], link.to_socket)
    rl.mute = True
out = []
for i in range(int(sys.argv[3]) + 1):
    r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    bpy.ops.render.render()
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    if i:  # (the first render compiles the scene's shaders: untimed)
        out.append([time.perf_counter() - t0, r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime])
print("TIMES", json.dumps(out))
'''


def _time(blend: Path, mode: str, n: int) -> list[list[float]]:
    env = dict(os.environ, BLENDER_USER_RESOURCES=tempfile.mkdtemp(prefix="ssgi-bench-user-"))
    p = subprocess.run([sys.executable, "-c", TIMER, str(blend), mode, str(n)],
                       capture_output=True, text=True, env=env)
    line = next((l for l in p.stdout.splitlines() if l.startswith("TIMES ")), None)
    if p.returncode != 0 or line is None:
        raise SystemExit(f"timing {blend} failed:\n{p.stderr[-3000:]}")
    return json.loads(line[6:])


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True, help="a boxmlp checkpoint")
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--names", nargs="+", default=["living_room", "cornell_emissive"])
    ap.add_argument("--repeats", type=int, default=2, help="timed renders of each kind per process")
    ap.add_argument("--rounds", type=int, default=1, help="alternating rounds of the three processes")
    ap.add_argument("--out", default=None, help="folder for the .blend files (default: a temporary one)")
    a = ap.parse_args(argv)
    from scenes import artist as A
    from ssgi.ssgi_addon.pipeline import setup

    size = tuple(int(v) for v in a.size.lower().split("x"))
    out = Path(a.out or tempfile.mkdtemp(prefix="ssgi-compiled-cost-"))
    out.mkdir(parents=True, exist_ok=True)
    results = []
    for name in a.names:
        sc = A.build(name, size)
        sc.eevee.taa_render_samples = a.samples
        blend = A.save(sc, out / f"{name}.blend")
        info = setup.run(setup.SetupConfig(blend=str(blend), out=str(out / f"{name}_compiled.blend"),
                                           model=a.model, compiled=True))
        times = {"eevee_gi": [], "compiled": [], "compiled_no_group": [], "group_only": []}
        for _ in range(a.rounds):
            times["eevee_gi"] += _time(blend, "on", a.repeats)
            times["compiled"] += _time(Path(info["out"]), "on", a.repeats)
            times["compiled_no_group"] += _time(Path(info["out"]), "off", a.repeats)
            times["group_only"] += _time(Path(info["out"]), "group", a.repeats)
        med = {k: [statistics.median(t[0] for t in v), statistics.median(t[1] for t in v)] for k, v in times.items()}
        res = dict(scene=name, size=list(size), samples=a.samples, nodes=info["nodes"],
                   wall_s={k: round(v[0], 3) for k, v in med.items()}, cpu_s={k: round(v[1], 3) for k, v in med.items()},
                   ratio_wall=round(med["compiled"][0] / med["eevee_gi"][0], 3),
                   ratio_cpu=round(med["compiled"][1] / med["eevee_gi"][1], 3),
                   times=times)
        print(json.dumps(res), flush=True)
        results.append(res)
    return results


if __name__ == "__main__":
    main()
