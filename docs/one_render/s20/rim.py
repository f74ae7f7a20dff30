"""Session 20: what the reflection map does on the glossy edge pixels it used to leave to EEVEE. On a shot fit's
validation views, with the map as fitted: its validation ceiling (Cycles' diffuse part + EEVEE's rest + lam x map)
with the edges left out (before session 20) and corrected (now), and the PSNR of the edge band alone.

    .venv/bin/python docs/one_render/s20/rim.py /tmp/s20/fits/cornell1r.fit /tmp/s20/fits/cornell1r.reflmap.npz
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
import cli  # noqa: E402
cli.load_package()
import numpy as np  # noqa: E402
from ssgi.model import metrics  # noqa: E402
from ssgi.model.infer import reflmap as rm  # noqa: E402
from ssgi.model.learn import reflmap as lrm  # noqa: E402
from ssgi.ssgi_addon.blender import views as fviews  # noqa: E402
from ssgi.ssgi_addon.pipeline import fit as pfit  # noqa: E402

work = Path(sys.argv[1])
plan = json.loads((work / "views_plan.json").read_text())
data = next(p for p in work.glob("views-*") if p.is_dir())
train, val, test = fviews.split_views(data, plan)
cams = pfit._view_cameras(None, data, plan, print)
field = rm.ReflectionMap.load(sys.argv[2])
glossy = rm.glossy_mask
before = lambda g, edges=False: glossy(g, edges=False)  # noqa: E731  (edges left to EEVEE)
now = lambda g, edges=False: glossy(g, edges=True)  # noqa: E731  (every glossy pixel)
for name, fn in (("edges excluded (before)", before), ("edges included (now)", now)):
    rm.glossy_mask = fn
    lam, scores = lrm.choose_weight(field, data, cams, val)
    pool, n = metrics.PooledPSNR(), 0  # the edge band alone: the pixels the two masks differ on
    for k in val:
        g, c = lrm._read(data, k), cams[str(k)]
        band = now(g) & ~before(g)
        n += int(band.sum())
        corr = field.correction(g, c["M"], c["P"], lam=1.0)
        pool.add(np.maximum(g["ref_diffuse"][..., :3] + g["rest"][..., :3] + corr, 0)[band], g["ref"][..., :3][band])
    print(name, {k: round(v, 3) for k, v in scores.items()}, "band px", n, "band PSNR", round(pool.value, 2))
rm.glossy_mask = glossy
