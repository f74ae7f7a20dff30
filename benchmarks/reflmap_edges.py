"""Benchmark: what a shot's reflection map does on the glossy edge pixels (silhouettes, gloss edges) it
learns nothing from. Two parts, on a finished shot fit (``cli.py fit --frames ...``; FIT.fit is its work folder):

- ``--val``: on the fit's validation views, with the map as fitted, the map's validation ceiling (Cycles' diffuse
  part + EEVEE's rest + lam x map) with the edges left to EEVEE and corrected (what the map does), and the
  PSNR of the edge band alone;
- ``--withheld``: the shot's withheld frames re-rendered and re-scored with the current code, the model unchanged
  (``pipeline.fit.render_withheld``; sheets into --out).

    .venv/bin/python benchmarks/reflmap_edges.py --fit-dir cornell1r.fit --model cornell1r.pt --val
    .venv/bin/python benchmarks/reflmap_edges.py --fit-dir cornell1r.fit --model cornell1r.pt --withheld --out DIR
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import _bootstrap  # noqa: F401,E402  (the checkout as package ssgi)
import numpy as np  # noqa: E402

from ssgi.model import metrics  # noqa: E402
from ssgi.model.errors import UserError  # noqa: E402


def val_edges(work: Path, model: Path) -> None:
    from ssgi.model.infer import reflmap as rm
    from ssgi.model.learn import reflmap as lrm
    from ssgi.ssgi_addon.blender import views as fviews
    from ssgi.ssgi_addon.pipeline import fit as pfit
    plan = json.loads((work / "views_plan.json").read_text())
    data = next(p for p in work.glob("views-*") if p.is_dir())
    _train, val, _test = fviews.split_views(data, plan)
    cams = pfit._view_cameras(None, data, plan, print)
    field = rm.ReflectionMap.load(rm.path_for(model))
    glossy = rm.glossy_mask
    before = lambda g, edges=False: glossy(g, edges=False)  # noqa: E731  (edges left to EEVEE)
    now = lambda g, edges=False: glossy(g, edges=True)  # noqa: E731  (every glossy pixel)
    try:
        for name, fn in (("edges excluded (before)", before), ("edges included (now)", now)):
            rm.glossy_mask = fn
            _lam, scores = lrm.choose_weight(field, data, cams, val)
            pool, n = metrics.PooledPSNR(), 0  # the edge band alone: the pixels the two masks differ on
            for k in val:
                g, c = lrm._read(data, k), cams[str(k)]
                band = now(g) & ~before(g)
                n += int(band.sum())
                corr = field.correction(g, c["M"], c["P"], lam=1.0)
                pool.add(np.maximum(g["ref_diffuse"][..., :3] + g["rest"][..., :3] + corr, 0)[band],
                         g["ref"][..., :3][band])
            print(name, {k: round(v, 3) for k, v in scores.items()}, "band px", n, "band PSNR", round(pool.value, 2))
    finally:
        rm.glossy_mask = glossy


def withheld(work: Path, model: Path, out, ref_samples: int) -> None:
    from ssgi.model.evaluate import fit_report
    from ssgi.ssgi_addon.pipeline import fit as pfit
    plan = json.loads((work / "views_plan.json").read_text())
    frames = pfit.render_withheld(plan.get("blend"), plan, plan.get("size"), str(model), None, ref_samples,
                                  Path(out) if out else None)
    for k, v in fit_report.score_withheld(frames)["methods"].items():
        print(k, round(v["psnr"], 2), round(v["ssim"], 3), {a: round(b, 2) for a, b in v["per_frame"].items()})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fit-dir", required=True, help="the fit's work folder (MODEL.fit)")
    ap.add_argument("--model", required=True, help="the fitted checkpoint (its .reflmap.npz beside it)")
    ap.add_argument("--val", action="store_true", help="the validation views' ceiling, edges left out and corrected")
    ap.add_argument("--withheld", action="store_true", help="re-render and re-score the withheld frames")
    ap.add_argument("--out", default=None, help="with --withheld: write the frames' PNG sheets here")
    ap.add_argument("--ref-samples", type=int, default=16, help="the references' Cycles samples (the fit's: 16)")
    a = ap.parse_args(argv)
    work, model = Path(a.fit_dir), Path(a.model)
    try:
        if not (work / "views_plan.json").is_file():
            raise UserError(f"--fit-dir {work}: no views_plan.json (not a fit's work folder)")
        if not model.is_file():
            raise UserError(f"--model {model}: no such file")
        if a.val:
            val_edges(work, model)
        if a.withheld:
            withheld(work, model, a.out, a.ref_samples)
    except UserError as e:
        print(f"reflmap_edges.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
