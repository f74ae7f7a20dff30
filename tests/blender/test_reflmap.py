"""A shot's reflection map on real Blender (model/infer/reflmap.py): a shot fit of a scene with a mirror bakes
EEVEE's rest and Glossy Color into its views, fits the map beside the model and reports it; a diffuse shot is told
apart and bakes no rest; and the node's render path adds weight x gloss x field to EEVEE's rest exactly on the glossy
pixels. The shot is scenes/shots.py's "cornell_emissive" (the artist test set's Cornell box lit by an emissive panel,
with a mirror ball; the camera pushes in) at 96x54 over 20 frames, EEVEE at 1 sample. The bpy-free half is
tests/unit/test_reflmap.py."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from ..conftest import ROOT, run_cli, run_py
from ..unit.test_fit import ABLATE_ALL, generic  # noqa: F401  (generic: a fixture)

SHOT = (1, 20)
pytestmark = pytest.mark.timeout(2400)


@pytest.fixture(scope="module")
def mirror_fit(tmp_path_factory, generic):
    d = tmp_path_factory.mktemp("reflmap_fit")
    blend, ripple = d / "cornell.blend", d / "ripple.blend"
    glossy = d / "glossy.json"
    run_py(f'''
import json
sys.path.insert(0, {str(ROOT)!r})
from scenes import shots as shot_scenes
from ssgi.ssgi_addon.pipeline.fit import has_glossy
found = {{}}
for name, path in (("ripple", {str(ripple)!r}), ("cornell_emissive", {str(blend)!r})):
    sc = shot_scenes.build(name, (96, 54), {SHOT[1]})
    sc.eevee.taa_render_samples = 1
    found[name] = has_glossy(sc)
    shot_scenes.save(sc, path)
json.dump(found, open({str(glossy)!r}, "w"))
''', timeout=180)
    model = d / "shot.pt"
    p = run_cli("fit", "--blend", str(blend), "--out", str(model), "--frames", f"{SHOT[0]}-{SHOT[1]}", "--views", "6",
                "--minutes", "0.5", "--size", "96x54", "--ref-samples", "2", "--init", str(generic), "--drop-tol",
                str(ABLATE_ALL), "--min-run-seconds", "1", "--threads", "1", "--crop", "32", "--json",
                timeout=2400)
    return dict(dir=d, blend=blend, model=model, summary=json.loads(p.stdout), glossy=json.loads(glossy.read_text()),
                log=p.stderr)


def test_a_mirror_shot_bakes_rest_and_gloss_and_fits_a_reflection_map(mirror_fit):
    from ssgi.model.dataset import exrio, folder as data_folder
    from ssgi.model.evaluate import fit_report
    from ssgi.model.infer import reflmap as rm
    from ssgi.model.learn import reflmap as lrm
    # the Cornell box's mirror ball is glossy; the ripple's Principled materials (roughness >= 0.3) are not
    assert mirror_fit["glossy"] == {"ripple": False, "cornell_emissive": True}
    work = mirror_fit["dir"] / "shot.fit"
    plan = json.loads((work / "views_plan.json").read_text())
    assert plan["rest_samples"] == 1  # the scene's own EEVEE samples: the rest as the node renders it
    (views,) = [p for p in work.glob("views-*") if p.is_dir()]
    m = data_folder.open_folder(views, scenes=True)
    assert {"rest", "gloss"} <= set(data_folder.stored_groups(m))
    assert m["settings"]["eevee"]["rest"]["samples"] == 1
    g = exrio.read_sample(data_folder.sample_path(views, sorted(m["samples"])[0]), ("gloss", "albedo", "depth", "normal"))
    ball = rm.glossy_mask(g)
    assert 30 < ball.sum() < 0.2 * ball.size  # the ball, not the diffuse walls
    assert (g["albedo"][ball] < 0.05).all()  # a metal: no diffuse colour where it reflects
    # the map beside the model, its weight chosen on the validation views, in the report
    rep = json.loads(fit_report.report_paths(mirror_fit["model"])[0].read_text())
    r = rep["reflmap"]
    assert r["points"] >= lrm.MIN_POINTS and r["lam"] in lrm.LAMBDAS
    assert r["val_psnr"][str(r["lam"])] == max(r["val_psnr"].values())
    assert r["file"] == str(rm.path_for(mirror_fit["model"])) and rm.path_for(mirror_fit["model"]).is_file()
    assert rm.ReflectionMap.load(r["file"]).lam == r["lam"]
    assert "## Shot reflection map" in fit_report.report_paths(mirror_fit["model"])[1].read_text()
    # the withheld frames: the ceiling with the node's rest and with EEVEE's own
    methods = rep["withheld"]["methods"]
    assert "oracle_diffuse" in methods and ("oracle_eevee_rest" in methods) == (r["lam"] > 0)


def test_the_node_adds_the_map_to_eevees_rest_on_the_glossy_pixels(mirror_fit, tmp_path):
    from ssgi.model.infer import reflmap as rm
    model = tmp_path / "rm.pt"
    shutil.copy(mirror_fit["model"], model)
    din = rm.n_features(1, 1)
    rm.ReflectionMap([(np.zeros((3, din)), np.array([0.5, 0.25, 0.0]))], [0, 0, 0], [1, 1, 1], 1, 1,
                     lam=1.0).save(rm.path_for(model))
    out = tmp_path / "node.npz"
    run_py(f'''
import bpy, numpy as np
from ssgi.ssgi_addon.blender.compositor import setup_scene
from ssgi.ssgi_addon.pipeline.render import RenderSession
bpy.ops.wm.open_mainfile(filepath={str(mirror_fit["blend"])!r})
sc = bpy.context.scene
setup_scene(sc, {str(model)!r})
s = RenderSession(sc, frames=[10], model={str(model)!r}, write=False, keep_groups=True)
assert s.reflmap is not None and "gloss" in s.groups
info = next(s.iter_frames())
g = info["groups"]
np.savez({str(out)!r}, **{{k: g[k] for k in ("gloss", "depth", "normal", "rest", "rest_eevee")}})
''', timeout=600)
    r = dict(np.load(out))
    mask = rm.glossy_mask(r, edges=True)  # every glossy pixel, the ball's silhouette too
    assert mask.sum() > 30 and (mask & ~rm.glossy_mask(r)).any()
    added = r["rest"] - r["rest_eevee"][..., :3]
    assert np.abs(added[~mask]).max() == 0.0  # walls, box, sky: EEVEE's own rest
    expect = r["gloss"][..., :3] * np.array([0.5, 0.25, 0.0], np.float32)
    assert np.abs(added[mask] - expect[mask]).max() < 1e-5 and added[mask][:, 0].min() > 0.2
