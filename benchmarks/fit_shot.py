"""Fit a shot, scored on withheld frames, and the equal-total-time comparison at 960x540.

    .venv/bin/python benchmarks/fit_shot.py --out OUT [--shots living_room room] [--size 240x135] [--frames 48]
        [--views 24] [--minutes 15] [--threads 2] [--time-size 960x540] [--skip-fit]

For each shot of scenes/shots.py: builds OUT/NAME.blend, runs ``cli.py fit --blend OUT/NAME.blend
--out OUT/NAME.pt --frames 1-N`` (bake included, one budget), and collects the report's withheld-frame scores
(the fitted model as the node renders it, the generic shipped model, Cycles 1 spp + OIDN, against Cycles 16 spp
+ OIDN). Then, on the first shot at ``--time-size``: one SSGI frame through the render path with the fitted
model, and Cycles 1 spp and 4 spp + OIDN frames, timed; Cycles' time a frame is extrapolated linearly in spp
(t = a + b * spp from the two), and the spp at which N Cycles frames cost as much as the fit plus N SSGI frames
is reported (an extrapolation from 1-2 frames each, not N renders). Writes OUT/fit_shot.json and OUT/fit_shot.md;
``uptime`` is recorded with every time (the machine is shared).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
from scenes import shots as shot_scenes  # noqa: E402


def uptime() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "?"


def fit_one(name, blend, out_dir, frames, views, minutes, threads) -> dict:
    model = out_dir / f"{name}.pt"
    cmd = [sys.executable, str(_bootstrap.ROOT / "cli.py"), "fit", "--blend", str(blend), "--out", str(model),
           "--frames", f"1-{frames}", "--views", str(views), "--minutes", f"{minutes:g}", "--json"]
    if threads:
        cmd += ["--threads", str(threads)]
    load0 = uptime()
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    (out_dir / f"{name}.fit.log").write_text(p.stderr)
    if p.returncode != 0:
        raise SystemExit(f"{name}: cli.py fit exited {p.returncode}: {p.stderr[-2000:]}")
    s = json.loads(p.stdout)
    return dict(name=name, model=str(model), wall_s=wall, load_before=load0, load_after=uptime(),
                fit_minutes=s["total_minutes"], bake_minutes=s["bake_minutes"], withheld_minutes=s.get("withheld_minutes"),
                inputs=s["inputs"], arch=s["final"]["arch"], verdict=s["verdict"], withheld=s["withheld"],
                command=" ".join(cmd[1:]))


def time_frames(blend, model, size, frame: int) -> dict:
    """Seconds of one SSGI frame (render path, fitted model, file's EEVEE samples) and of Cycles 1 and 4 spp +
    OIDN frames at ``size``, each with the load average."""
    import bpy

    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    from ssgi.ssgi_addon.blender.scene_state import preserved
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    passes.set_resolution(scene, *size)
    setup_scene(scene, str(model))
    out = {"size": list(size), "frame": frame}
    ses = RenderSession(scene, frames=[frame], model=str(model), write=False)
    (info,) = list(ses.iter_frames())
    out["ssgi"] = dict(seconds=info["t_total"], passes=info["t_passes"], predict=info["t_predict"],
                       per_render=info["t_pass_renders"], load=uptime())
    scene.frame_set(frame)
    for spp in (1, 4):
        with preserved(scene):
            t = time.perf_counter()
            passes.render_cycles(scene, spp, seed=1, denoise=True)
            out[f"cycles_{spp}spp_oidn"] = dict(seconds=time.perf_counter() - t, load=uptime())
    return out


def equal_time(fit_s: float, t: dict, n: int) -> dict:
    a1, a4 = t["cycles_1spp_oidn"]["seconds"], t["cycles_4spp_oidn"]["seconds"]
    b = max(1e-6, (a4 - a1) / 3.0)
    a = a1 - b
    ssgi_total = fit_s + n * t["ssgi"]["seconds"]
    spp = (ssgi_total / n - a) / b
    return dict(frames=n, fit_s=fit_s, ssgi_frame_s=t["ssgi"]["seconds"], ssgi_total_s=ssgi_total,
                cycles_s_per_frame=dict(a=a, b_per_spp=b), cycles_1spp_total_s=n * a1,
                equal_time_spp=spp, note="extrapolated from 1 SSGI frame and 1 Cycles frame at 1 and 4 spp")


def markdown(res: dict) -> str:
    L = ["# fit_shot benchmark", "", f"Command: `{res['command']}`", ""]
    for f in res["fits"]:
        w = f["withheld"]
        L += [f"## {f['name']}", "", f"`{f['command']}`", "",
              f"Fit {f['fit_minutes']:.2f} min (bake {f['bake_minutes']:.2f}), scoring the withheld frames "
              f"{(f['withheld_minutes'] or 0):.2f} min; load average {f['load_before']} -> {f['load_after']}. "
              f"Kept {f['arch']} on {', '.join(f['inputs'])}.", "", f"**{f['verdict']}**", "",
              "| method | PSNR | tonemapped | SSIM | s/frame | " + " | ".join(f"f{x}" for x in w["frames"]) + " |",
              "|---|---:|---:|---:|---:|" + "---:|" * len(w["frames"])]
        for m, r in w["methods"].items():
            L.append(f"| {m} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} | {r['ssim']:.3f} | {r['seconds'] or 0:.1f} | "
                     + " | ".join(f"{r['per_frame'][str(x)]:.2f}" for x in w["frames"]) + " |")
        L.append("")
    if res.get("timing"):
        t, e = res["timing"], res["equal_time"]
        L += ["## Equal total time", "", f"At {t['size'][0]}x{t['size'][1]}, frame {t['frame']} of "
              f"{res['fits'][0]['name']}: SSGI frame {t['ssgi']['seconds']:.1f} s (passes {t['ssgi']['passes']:.1f}, "
              f"predict {t['ssgi']['predict']:.2f}; load {t['ssgi']['load']}), Cycles 1 spp + OIDN "
              f"{t['cycles_1spp_oidn']['seconds']:.1f} s, 4 spp + OIDN {t['cycles_4spp_oidn']['seconds']:.1f} s.", "",
              f"{e['frames']} frames: fit {e['fit_s'] / 60:.1f} min + {e['frames']} SSGI frames = "
              f"{e['ssgi_total_s'] / 60:.1f} min; {e['frames']} Cycles 1 spp + OIDN frames = "
              f"{e['cycles_1spp_total_s'] / 60:.1f} min; equal time buys Cycles about {e['equal_time_spp']:.0f} spp "
              f"+ OIDN a frame ({e['note']}).", ""]
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--shots", nargs="+", default=["living_room", "room"], choices=shot_scenes.NAMES)
    ap.add_argument("--size", default="240x135")
    ap.add_argument("--frames", type=int, default=48)
    ap.add_argument("--views", type=int, default=24)
    ap.add_argument("--minutes", type=float, default=15.0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--time-size", default="960x540")
    ap.add_argument("--skip-fit", action="store_true", help="reuse OUT/fit_shot.json's fits (timing only)")
    a = ap.parse_args(argv)
    from ssgi.model import cliargs, files
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    size = cliargs.parse_size(a.size)
    res_path = out / "fit_shot.json"
    res = json.loads(res_path.read_text()) if a.skip_fit and res_path.is_file() else {"fits": []}
    res["command"] = "benchmarks/fit_shot.py " + " ".join(argv if argv is not None else sys.argv[1:])
    if not a.skip_fit:
        for name in a.shots:
            blend = shot_scenes.save(shot_scenes.build(name, size, a.frames), out / f"{name}.blend")
            print(f"{name}: fitting", file=sys.stderr, flush=True)
            r = fit_one(name, blend, out, a.frames, a.views, a.minutes, a.threads)
            print(f"{name}: {r['verdict']} (fit {r['fit_minutes']:.2f} min)", file=sys.stderr, flush=True)
            res["fits"].append(r)
            files.write_json(res_path, res, indent=1)
    if a.time_size and res["fits"]:
        f0 = res["fits"][0]
        t = time_frames(out / f"{f0['name']}.blend", f0["model"], cliargs.parse_size(a.time_size), (1 + a.frames) // 2)
        res.update(timing=t, equal_time=equal_time(60.0 * f0["fit_minutes"], t, a.frames))
    files.write_json(res_path, res, indent=1)
    files.write_text(out / "fit_shot.md", markdown(res))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
