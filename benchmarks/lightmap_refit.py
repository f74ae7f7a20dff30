"""Re-fit a shot model's lightmap and score its withheld frames: the fit's last steps on a model already written
(pipeline.fit.fit_shot_lightmap, then render_withheld + fit_report.score_withheld), as `cli.py fit` runs them.

    .venv/bin/python benchmarks/lightmap_refit.py MODEL.fit MODEL.pt SECONDS TARGET   # TARGET: ref_diffuse | ref_minus_rest

MODEL.fit is the fit's work folder (views_plan.json, the views). Writes MODEL.lightmap.npz, the sheets in
MODEL.withheld/ and MODEL.pt.after.json; prints the lightmap's report and each method's PSNR / SSIM / per frame.
"""
import argparse, json, time
import _bootstrap  # noqa: F401  (the checkout as package "ssgi")
from pathlib import Path
from ssgi.ssgi_addon.pipeline import fit as pf
from ssgi.ssgi_addon.blender import views as fviews
from ssgi.model.evaluate import fit_report
from ssgi.model import channels as ch
ap = argparse.ArgumentParser(description="Re-fit a shot model's lightmap and score its withheld frames.")
ap.add_argument("fitdir", type=Path, help="the fit's work folder (MODEL.fit: views_plan.json, the views)")
ap.add_argument("model", help="the fitted model (MODEL.pt)")
ap.add_argument("seconds", type=float, help="the lightmap's training budget in seconds")
ap.add_argument("target", choices=("ref_diffuse", "ref_minus_rest"), help="what the lightmap learns")
a = ap.parse_args()
fitdir, model, seconds, target = a.fitdir, a.model, a.seconds, a.target
plan = json.loads((fitdir / "views_plan.json").read_text())
data = [p for p in fitdir.glob("views-*") if p.is_dir()][0]
train, val, test = fviews.split_views(data, plan)
cams = pf._view_cameras(None, data, plan, print)
t = time.time()
rep = pf.fit_shot_lightmap(data, cams, train, val, model, target, seconds, 0, print)
print("lightmap", round(time.time() - t, 1), "s", json.dumps(rep))
frames = pf.render_withheld(plan["blend"], plan, plan["size"], model, str(_bootstrap.ROOT / "models" / "ssgi_default.pt"), 16,
                            Path(model).with_suffix(".withheld"), log=print)
w = fit_report.score_withheld(frames)
print(json.dumps({m: (round(r["psnr"], 2), round(r["ssim"], 3), r["per_frame"]) for m, r in w["methods"].items()}))
json.dump(dict(lightmap=rep, withheld=w), open(str(model) + ".after.json", "w"), default=str)
