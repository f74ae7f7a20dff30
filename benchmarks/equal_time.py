"""The equal-total-time comparison, measured: a fitted shot rendered whole at 960x540 with SSGI, against
Cycles + OIDN given the same total time, scored on the shot's withheld frames.

    .venv/bin/python benchmarks/equal_time.py --blend SHOT.blend --model SHOT.pt --fit-minutes M --out OUT \\
        [--size 960x540] [--frames 1-48] [--withheld 6,15,25,34,43] [--ref-samples 128] [--probe-samples 16]

Stages, each timed on this machine in one process, one after the other (``uptime`` recorded with each):

1. ``ssgi``: every frame of the range through the render path (``RenderSession``: EEVEE passes at the file's
   samples, the fitted model, the temporal mode as an animation render has it, the composite render, the image
   file written to OUT/ssgi/), as ``cli.py render --frames A-B`` renders them. Total = the sum of the frames'
   times (the model loads once, before the first frame, and is not counted; Blender's start is not counted).
2. ``cycles1``: every frame with Cycles 1 spp + OIDN (``passes.render_cycles``, the file's Cycles settings).
3. ``probe``: one frame (the middle withheld one) at ``--probe-samples`` spp + OIDN, for the line
   t(spp) = a + b spp through it and the 1-spp mean (while the probe costs under twice a 1-spp frame, it is
   rendered again at 4x the spp, up to ``--max-spp``); the equal-time spp S is where N frames at S cost the fit
   (``--fit-minutes``, the fit's own measured total, bake included) plus the N SSGI frames.
4. ``equal``: the withheld frames at S spp + OIDN, timed (their mean is what equal time buys a frame; the
   other frames are not rendered at S: that is the one extrapolation, from 5 frames to N).
5. ``refs``: the withheld frames at ``--ref-samples`` spp + OIDN, another seed (not timed).

Scores: PSNR pooled over the geometry pixels of the withheld frames, SSIM mean, as the fit report scores
(model/evaluate/fit_report.score_withheld). Each stage writes its times and its withheld images under OUT
(atomically) and is skipped when done: a killed run resumes at the stage (and, for ``ssgi``/``cycles1``, the
frame) it reached. Writes OUT/equal_time.json, OUT/equal_time.md and OUT/frame_NNNN.png sheets (reference |
SSGI | Cycles at S spp | Cycles 1 spp).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402
from fit_shot import uptime  # noqa: E402  (benchmarks/ is on sys.path: the scripts' folder)

STAGE_METHODS = {"ssgi": "SSGI (fitted model, node render path)", "equal": "Cycles + OIDN at equal total time",
                 "cycles1": "Cycles 1 spp + OIDN"}


class Store:
    """OUT/state.json (stage -> {frame: seconds}, extras) and OUT/img/METHOD_FRAME.npy, written atomically."""

    def __init__(self, out: Path):
        from ssgi.model import files
        self.files, self.out = files, out
        (out / "img").mkdir(parents=True, exist_ok=True)
        p = out / "state.json"
        self.state = json.loads(p.read_text()) if p.is_file() else {}

    def save(self):
        self.files.write_json(self.out / "state.json", self.state, indent=1)

    def times(self, stage: str) -> dict:
        return self.state.setdefault(stage, {}).setdefault("seconds", {})

    def put_image(self, method: str, frame: int, img) -> None:
        def write(tmp):
            with open(tmp, "wb") as fh:
                np.save(fh, np.asarray(img))
        self.files.atomic_write(self.out / "img" / f"{method}_{frame:04d}.npy", write)

    def image(self, method: str, frame: int):
        p = self.out / "img" / f"{method}_{frame:04d}.npy"
        return np.load(p) if p.is_file() else None


def open_scene(blend, size, model):
    import bpy

    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    passes.set_resolution(scene, *size)
    setup_scene(scene, str(model))
    return scene


def stage_ssgi(st: Store, scene, model, frames, withheld, log):
    from ssgi.model import images
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    secs = st.times("ssgi")
    todo = [f for f in frames if str(f) not in secs]
    if not todo:
        return
    # a resumed run starts a new session at the first frame not done; the render path's history cache (beside the
    # output frames) or, when that is gone, renders of the predecessors give it the frame an uninterrupted run
    # gives (docs/temporal.md), their time counted in the frame's; recorded in the state
    if len(todo) < len(frames):
        st.state["ssgi"].setdefault("resumed_at", []).append(todo[0])
    ses = RenderSession(scene, frames=todo, model=str(model), out=str(st.out / "ssgi" / "frame_####"), write=True,
                        keep_groups=True)
    st.state["ssgi"].update(temporal=ses.history is not None, working_res=str(ses.working_res))
    for info in ses.iter_frames():
        f = int(info["frame"])
        if f in withheld:
            st.put_image("ssgi", f, np.asarray(info["prediction"], np.float32))
            g = info["groups"]
            st.put_image("mask", f, images.geometry_mask(g["depth"], g["normal"]))
        secs[str(f)] = info["t_total"]
        st.state["ssgi"].setdefault("parts", {})[str(f)] = dict(passes=info["t_passes"], predict=info["t_predict"],
                                                                  composite=info["t_composite"])
        st.state["ssgi"].setdefault("load", {})[str(f)] = uptime()
        st.save()
        log(f"ssgi frame {f}: {info['t_total']:.1f} s (load {uptime()})")


def cycles_frames(st: Store, scene, stage: str, frames, spp: int, seed0: int, keep, log):
    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.scene_state import preserved
    secs = st.times(stage)
    st.state[stage]["spp"] = spp
    for f in frames:
        if str(f) in secs:
            continue
        scene.frame_set(f)
        with preserved(scene):
            t = time.perf_counter()
            img = passes.render_cycles(scene, spp, seed=seed0 + f, denoise=True)["ref"]
            s = time.perf_counter() - t
        if f in keep:
            st.put_image(stage, f, np.asarray(img, np.float32))
        secs[str(f)] = s
        st.state[stage].setdefault("load", {})[str(f)] = uptime()
        st.save()
        log(f"{stage} frame {f}: {spp} spp + OIDN {s:.1f} s (load {uptime()})")


def score(st: Store, withheld, methods) -> dict:
    from ssgi.model.evaluate import fit_report
    frames = []
    for f in withheld:
        ref, mask = st.image("refs", f), st.image("mask", f)
        frames.append(dict(frame=f, ref=ref, mask=mask, images={m: st.image(m, f) for m in methods}))
    return fit_report.score_withheld(frames)


def sheets(st: Store, withheld, methods):
    from ssgi.model import images
    for f in withheld:
        row = [st.image("refs", f)] + [st.image(m, f) for m in methods]
        sheet = np.concatenate([np.pad(np.asarray(x, np.float32), ((0, 0), (0, 4), (0, 0))) for x in row], axis=1)
        images.write_png(st.out / f"frame_{f:04d}.png", images.srgb8(sheet))


def markdown(res: dict) -> str:
    e = res["equal_time"]
    L = ["# Equal total time, measured", "", f"`{res['command']}`", "",
         f"{res['size'][0]}x{res['size'][1]}, frames {res['frames'][0]}-{res['frames'][-1]} ({e['n']} frames), "
         f"withheld frames {', '.join(map(str, res['withheld']))}, references Cycles {res['ref_samples']} spp + OIDN.", "",
         "| | seconds |", "|---|---:|",
         f"| the fit (bake included, its own measurement) | {e['fit_s']:.0f} |",
         f"| {e['n']} SSGI frames (measured, each) | {e['ssgi_s']:.0f} (a frame {e['ssgi_s'] / e['n']:.1f}) |",
         f"| fit + {e['n']} SSGI frames | **{e['fit_s'] + e['ssgi_s']:.0f}** |",
         f"| {e['n']} Cycles 1 spp + OIDN frames (measured, each) | {e['cycles1_s']:.0f} (a frame {e['cycles1_s'] / e['n']:.1f}) |",
         f"| probe: frame {e['probe_frame']} at {e['probe_spp']} spp + OIDN | {e['probe_s']:.1f} |",
         f"| equal time a frame (fit + SSGI) / {e['n']} | {e['budget_s']:.1f} -> Cycles at **{e['spp']} spp** + OIDN"
         + (f" (capped at --max-spp {e['max_spp']})" if e['spp'] >= e['max_spp'] else "") + " |",
         f"| the withheld frames at {e['spp']} spp + OIDN (measured, mean) | {e['equal_frame_s']:.1f} "
         f"(x {e['n']} = {e['equal_frame_s'] * e['n']:.0f}) |", "",
         "| method (withheld frames) | PSNR | PSNR (tonemapped) | SSIM | " +
         " | ".join(f"frame {f}" for f in res["withheld"]) + " |", "|---|---:|---:|---:|" + "---:|" * len(res["withheld"])]
    for m, r in res["scores"]["methods"].items():
        label = STAGE_METHODS.get(m, m) + (f" ({e['spp']} spp)" if m == "equal" else "")
        L.append(f"| {label} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} | {r['ssim']:.3f} | "
                 + " | ".join(f"{r['per_frame'][str(f)]:.2f}" for f in res["withheld"]) + " |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--blend", required=True)
    ap.add_argument("--model", required=True)
    ap.add_argument("--fit-minutes", type=float, required=True, help="the fit's whole time (its report's total)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--frames", default="1-48")
    ap.add_argument("--withheld", default="6,15,25,34,43")
    ap.add_argument("--ref-samples", type=int, default=128)
    ap.add_argument("--probe-samples", type=int, default=16)
    ap.add_argument("--max-spp", type=int, default=4096, help="the equal-time spp is capped here (default %(default)s)")
    a = ap.parse_args(argv)
    from ssgi.model import cliargs, files
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    size, frames = cliargs.parse_size(a.size), cliargs.parse_frames(a.frames)
    withheld = cliargs.parse_frames(a.withheld)
    if not set(withheld) <= set(frames):
        raise SystemExit(f"--withheld {a.withheld}: not all within --frames {a.frames}")

    def log(msg):
        print(f"{time.strftime('%H:%M:%S')} {msg}", file=sys.stderr, flush=True)

    st = Store(out)
    scene = open_scene(a.blend, size, a.model)
    stage_ssgi(st, scene, a.model, frames, set(withheld), log)
    cycles_frames(st, scene, "cycles1", frames, 1, 0, set(withheld), log)
    n = len(frames)
    ssgi_s, cyc1 = sum(st.times("ssgi").values()), st.times("cycles1")
    mid = withheld[len(withheld) // 2]
    a1 = float(np.mean(list(cyc1.values())))
    probe_spp = a.probe_samples
    while True:  # the probe must cost clearly more than 1 spp, or the line's slope is noise: 4x the spp until it does
        stage = "probe" if probe_spp == a.probe_samples else f"probe{probe_spp}"
        cycles_frames(st, scene, stage, [mid], probe_spp, 0, set(), log)
        probe_s = st.times(stage)[str(mid)]
        if probe_s >= 2.0 * a1 or probe_spp >= a.max_spp:
            break
        probe_spp = min(a.max_spp, 4 * probe_spp)
    b = max(1e-6, (probe_s - a1) / max(1, probe_spp - 1))
    budget = (60.0 * a.fit_minutes + ssgi_s) / n
    spp = int(min(a.max_spp, max(1, (budget - (a1 - b)) // b)))
    if st.state.get("equal", {}).get("spp") not in (None, spp):  # a resumed run keeps the spp it started with
        spp = st.state["equal"]["spp"]
    cycles_frames(st, scene, "equal", withheld, spp, 0, set(withheld), log)
    cycles_frames(st, scene, "refs", withheld, a.ref_samples, 100003, set(withheld), log)
    methods = ["ssgi", "equal", "cycles1"]
    res = dict(command="benchmarks/equal_time.py " + " ".join(argv if argv is not None else sys.argv[1:]),
               size=list(size), frames=frames, withheld=withheld, ref_samples=a.ref_samples,
               equal_time=dict(n=n, fit_s=60.0 * a.fit_minutes, ssgi_s=ssgi_s, cycles1_s=float(sum(cyc1.values())),
                               probe_frame=mid, probe_spp=probe_spp, max_spp=a.max_spp, probe_s=probe_s, budget_s=budget, spp=spp,
                               line=dict(a=a1 - b, b_per_spp=b),
                               equal_frame_s=float(np.mean(list(st.times("equal").values())))),
               ssgi=st.state["ssgi"], scores=score(st, withheld, methods))
    sheets(st, withheld, methods)
    files.write_json(out / "equal_time.json", res, indent=1)
    files.write_text(out / "equal_time.md", markdown(res))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
