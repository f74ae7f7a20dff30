"""Which shot lightmap, and how much of it: lightmap variants scored on a shot's withheld frames without Blender
(docs/fit.md).

Two steps:

    # 1. (Blender) render a fitted shot model's withheld frames once through the node's render path and keep, per
    #    frame, its passes, the network's stateless prediction, the camera and Cycles 16 spp + OIDN references
    .venv/bin/python benchmarks/lightmap_variants.py cache --plan MODEL.fit/views_plan.json --model MODEL.pt --out WH
    # 2. (bpy-free) fit lightmap variants on the shot's views and score each blend weight on those frames
    .venv/bin/python benchmarks/lightmap_variants.py score --views VIEWS --plan PLAN --target ref_diffuse --frames WH \\
        --variants bound,none,known --seconds 120 [--known direct_soft] [--edge-spread]

Variants: ``bound`` (a perfect lightmap: the reference's own light where the node blends; what any lightmap can
add), ``none`` (the field of the whole diffuse light), ``known`` (the field of the light minus the frame's own
``--known`` direct-light passes, added back per frame: model/infer/lightmap.py). Each prints, for every weight of
model/learn/lightmap.LAMBDAS, the pooled PSNR over the frames and the per-frame PSNRs, scored as the fit's withheld
scoring scores (fit_report.score_withheld: geometry pixels, the network's diffuse part composed with EEVEE's rest).
The network is scored stateless (no temporal mode), as ``fitted_network`` is. ``--edge-rule`` keeps the network on
edge pixels, ``--edge-spread`` spreads the depth term over 3 x 3
pixels (wider edge bands), for comparison. Fields are trained for ``--seconds`` of
wall time, so a loaded machine trains fewer steps; the steps are printed.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import _bootstrap  # noqa: F401  (the checkout as package "ssgi")
import numpy as np


def cache(a) -> None:
    from ssgi.ssgi_addon.blender import passes
    from ssgi.ssgi_addon.blender.blendfile import check_blend, open_blend, pick_scene
    from ssgi.ssgi_addon.blender.compositor import setup_scene
    from ssgi.ssgi_addon.blender.scene_state import preserved
    from ssgi.ssgi_addon.blender.views import camera_matrices
    from ssgi.ssgi_addon.pipeline.render import RenderSession
    plan = json.loads(Path(a.plan).read_text())
    blend = check_blend(plan["blend"])
    open_blend(blend)
    scene = pick_scene(blend, plan.get("scene"))
    scene.camera = scene.objects[plan["test_camera"]]
    passes.set_resolution(scene, *plan["size"])
    setup_scene(scene, a.model)
    s = RenderSession(scene, frames=list(plan["test_frames"]), model=a.model, write=False, keep_groups=True)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for info in s.iter_frames():
        g, f = info["groups"], int(info["frame"])
        c = camera_matrices(scene)
        with preserved(scene):
            refs = passes.render_cycles(scene, a.ref_samples, seed=100003 + f, denoise=True, groups=("ref", "ref_diffuse"))
        np.savez(out / f"f{f:04d}.npz", net=s.predict_network(g), M=np.asarray(c["M"]), P=np.asarray(c["P"]),
                 ref=refs["ref"], ref_diffuse=refs["ref_diffuse"], **{"g_" + k: np.asarray(v) for k, v in g.items()})
        print(f"frame {f} cached", flush=True)


def score(a) -> None:
    import torch

    from ssgi.model import channels as ch, metrics
    from ssgi.model.images import geometry_mask
    from ssgi.model.infer import lightmap as lm
    from ssgi.model.infer.compose import compose
    from ssgi.model.learn import lightmap as llm
    torch.set_num_threads(a.threads)
    if a.edge_spread:  # the wider rule: the depth term spread over 3 x 3 pixels
        src = Path(lm.__file__).read_text()
        code = src[src.index("def edges("):src.index("def blend_weight(")]
        code = code.replace("e = d2 > EDGE_DEPTH * iz", "e = spread((d2 > EDGE_DEPTH * iz).astype(np.float32)) > 0")
        ns = dict(lm.__dict__)
        exec(code, ns)  # noqa: S102  (this module's own function, one line changed)
        lm.edges = ns["edges"]
    data, plan = Path(a.views), json.loads(Path(a.plan).read_text())
    cams = json.loads((data / "cameras.json").read_text())
    val_cams = {c for c, role in plan["cameras"].items() if role == "val"}
    keys = sorted(k for k in cams)
    from ssgi.ssgi_addon.blender import views as fviews
    train, val, _ = fviews.split_views(data, plan)
    frames = []
    for p in sorted(Path(a.frames).glob("f*.npz")):
        z = np.load(p)
        frames.append(dict(frame=int(p.stem[1:]), g={k[2:]: z[k] for k in z.files if k.startswith("g_")}, net=z["net"],
                           M=z["M"], P=z["P"], ref=z["ref"][..., :3], ref_diffuse=z["ref_diffuse"][..., :3]))
    if not frames:
        sys.exit(f"{a.frames}: no cached frames (f*.npz); run the cache step first")
    if a.model:  # another network on the same cached passes (the cache's model must read every input it reads)
        from ssgi.model.infer.predictor import load_predictor
        from ssgi.model.infer.workres import WorkingResolution
        pr = WorkingResolution(load_predictor(a.model, num_threads=a.threads, runtime="torch"), "auto")
        want = tuple(pr.required) + ("normal", "depth", "albedo")  # as RenderSession.predict_network asks
        lacking = sorted({g for g in want for f in frames if g not in f["g"]})
        if lacking:
            sys.exit(f"{a.frames}: the cached passes lack {', '.join(lacking)}, which {a.model} reads; cache the "
                     f"frames with a model that reads them (e.g. the shipped model)")
        for f in frames:
            f["net"] = pr.predict({g: f["g"][g] for g in dict.fromkeys(want)})
    known = tuple(k for k in a.known.split("+") if k)

    def scored(lights):
        out = {}
        for lam in llm.LAMBDAS:
            pool, per = metrics.PooledPSNR(), []
            for f, L in zip(frames, lights):
                w = lm.blend_weight(f["g"], lam, network_on_edges=a.edge_rule or a.edge_spread)[..., None]
                part = w * f["g"]["albedo"][..., :3] * L + (1 - w) * f["net"]
                r = metrics.score(compose(part, f["g"], ch.DIFFUSE_TARGET, None), f["ref"],
                                  geometry_mask(f["g"]["depth"], f["g"]["normal"]), with_ssim=False, with_flip=False)
                pool.add_score(r)
                per.append(round(r["psnr"], 2))
            out[lam] = (round(pool.value, 3), per)
        return out
    print(json.dumps(dict(shot=str(data), train=len(train), val=len(val), frames=[f["frame"] for f in frames],
                          val_cameras=sorted(val_cams), views=len(keys))))
    print("network alone", scored([np.zeros_like(f["net"]) for f in frames])[0.0])  # weight 0: the network
    for v in a.variants.split(","):
        t = time.time()
        if v == "bound":
            def light(f):
                g = f["g"]
                tg = f["ref_diffuse"] if a.target == "ref_diffuse" else np.maximum(f["ref"] - g["rest"][..., :3], 0)
                return tg / np.maximum(g["albedo"][..., :3], lm.ALBEDO_MIN)
            print("bound (a perfect lightmap)", json.dumps(scored([light(f) for f in frames])))
            continue
        kn = known if v == "known" else ()
        pos, nrm, y = llm.points(data, cams, train, a.target, kn)
        field, st = llm.train_field(pos, nrm, y, a.seconds, known=kn)
        lights = [field.light(f["g"], f["M"], f["P"]) for f in frames]
        print(f"{v} ({'+'.join(kn) or 'whole light'}; {st['steps']} steps, {time.time() - t:.0f} s)",
              json.dumps(scored(lights)), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cache", help="render a shot model's withheld frames once (Blender)")
    c.add_argument("--plan", required=True, help="the fit's views_plan.json (blend, withheld frames, camera, size)")
    c.add_argument("--model", required=True, help="the fitted shot model (.pt)")
    c.add_argument("--out", required=True, help="folder for the cached frames (fNNNN.npz)")
    c.add_argument("--ref-samples", type=int, default=16)
    s = sub.add_parser("score", help="fit lightmap variants and score them on the cached frames (no Blender)")
    s.add_argument("--views", required=True, help="the fit's views folder (views-*/, with cameras.json)")
    s.add_argument("--plan", required=True, help="the fit's views_plan.json")
    s.add_argument("--target", required=True, choices=("ref_diffuse", "ref_minus_rest"))
    s.add_argument("--frames", required=True, help="the cache step's folder")
    s.add_argument("--variants", default="bound,none,known")
    s.add_argument("--known", default="direct_soft", help="the known-light groups, joined by + (e.g. direct+emit_direct)")
    s.add_argument("--seconds", type=float, default=120.0)
    s.add_argument("--threads", type=int, default=2)
    s.add_argument("--model", default=None, help="score this network instead of the cached prediction (re-predicted "
                   "from the cached passes, stateless)")
    s.add_argument("--edge-rule", action="store_true",
                   help="the network, not the lightmap, on edge pixels (for comparison)")
    s.add_argument("--edge-spread", action="store_true", help="the depth edge term spread over 3 x 3 pixels, for comparison")
    a = ap.parse_args()
    (cache if a.cmd == "cache" else score)(a)


if __name__ == "__main__":
    main()
