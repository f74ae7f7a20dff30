"""Bad input: a scene setup the SSGI path cannot handle is refused (UserError, one line naming the
object/material/setting and the fix) or rendered with a warning (stderr "SSGI: warning: ...", the node label,
the summary's "warnings", the operator's report). Each case of benchmarks/bad_input.py (which measured what each
does to the image, docs/node.md) is built on the tiny emissive/metal/glass/glossy scene with a random model and
given to the real RenderSession; one warned scene is rendered with real EEVEE at 64x36 and still writes its frame."""
from __future__ import annotations

import json

import pytest

from ..conftest import ROOT, run_py

CODE = r'''
import json, os, sys
import bpy
import numpy as np
sys.path.insert(0, str(ROOT / "benchmarks"))
import bad_input
from ssgi.model.errors import UserError
from ssgi.ops.node_ops import SSGI_OT_render
from ssgi.ssgi_addon.pipeline.render import RenderSession

d = sys.argv[1]
models = {t: bad_input.make_model(f"{d}/{t}.pt", target=t) for t in ("ref_diffuse", "ref")}
res = {}
for case in bad_input.CASES:
    for target in (("ref_diffuse", "ref") if case == "volume_material" else ("ref_diffuse",)):
        sc, names, obj = bad_input.build_case(case, models[target])
        key = case if target == "ref_diffuse" else case + "/ref"
        try:
            s = RenderSession(sc, model=models[target], write=False)
            res[key] = {"fatal": None, "warnings": s.warnings, "label": s.label}
        except UserError as e:
            res[key] = {"fatal": str(e)}

# a warned render still writes its frame
sc, names, obj = bad_input.build_case("motion_blur", models["ref_diffuse"])
sc.eevee.taa_render_samples = 1
ims = sc.render.image_settings
ims.media_type, ims.file_format, ims.color_mode, ims.color_depth = "IMAGE", "OPEN_EXR", "RGBA", "32"
out = f"{d}/warned.exr"
print("RENDER-START", file=sys.stderr, flush=True)
s = RenderSession(sc, model=models["ref_diffuse"], out=out)
summary = s.run()
img = bad_input.read_exr(out)
res["render"] = {"warnings": summary["warnings"], "files": summary["files"], "labels": [n.label for n in s.nodes],
                 "shape": list(img.shape), "finite": bool(np.isfinite(img).all()),
                 "rgb": [float(v) for v in img[..., :3].reshape(-1, 3).mean(0)],
                 "report": SSGI_OT_render.summary_text(None, summary)}
print("RESULT", json.dumps(res))
'''


@pytest.fixture(scope="module")
def checked(tmp_path_factory):
    d = tmp_path_factory.mktemp("scene_checks")
    p = run_py(f"ROOT = __import__('pathlib').Path({str(ROOT)!r})\n" + CODE, str(d), timeout=900)
    res = json.loads(next(line for line in p.stdout.splitlines() if line.startswith("RESULT "))[7:])
    return res, p.stderr


def _warned(res, case, code_words):
    r = res[case]
    assert r["fatal"] is None, r
    text = " ".join(r["warnings"])
    for w in code_words:
        assert w in text, (case, w, r["warnings"])
    assert r["label"].startswith("SSGI: ") and "warning" in r["label"], r
    return r


def _refused(res, case, words):
    r = res[case]
    assert r["fatal"], (case, r)
    assert "\n" not in r["fatal"], r["fatal"]
    for w in words:
        assert w in r["fatal"], (case, w, r["fatal"])
    return r


def test_a_plain_scene_and_transparent_film_with_a_lit_world_get_no_finding(checked):
    res, _ = checked
    for case in ("baseline", "film_transparent"):  # film transparent: alpha measured equal to EEVEE's own
        assert res[case] == {"fatal": None, "warnings": [], "label": "SSGI"}, res[case]


def test_volumes(checked):
    res, _ = checked
    r = _warned(res, "volume_material", ["'fog_volume'", "'fog_cube'", "not dimmed"])
    assert "volume_material" in r["label"]
    _refused(res, "volume_material/ref", ["'fog_volume'", "whole image", "ref_diffuse"])
    _refused(res, "world_volume", ["world 'world'", "Volume", "unlink"])


def test_holdouts(checked):
    res, _ = checked
    _warned(res, "holdout_object", ["'tiny_metal'", "Holdout", "black surface"])
    _warned(res, "holdout_collection", ["'holdout_coll'", "view layer 'ViewLayer'"])
    _warned(res, "holdout_shader", ["material 'tiny_glossy_red' on 'tiny_glossy'", "Holdout shader"])


def test_light_groups_lights_and_emission(checked):
    res, _ = checked
    _warned(res, "light_group", ["'tiny_point'", "light group", "no light-group passes"])
    _warned(res, "light_no_shadow", ["'tiny_point'", "Shadow off"])
    _warned(res, "light_negative", ["'tiny_point'", "negative power", "as off"])
    _warned(res, "light_zero", ["'tiny_point'", "zero power"])
    _refused(res, "emission_negative", ["material 'tiny_emission'", "(-8)", "Emission Strength"])


def test_engine_and_motion_blur(checked):
    res, _ = checked
    _warned(res, "engine_cycles", ["Cycles", "EEVEE"])
    _warned(res, "engine_workbench", ["Workbench"])
    _warned(res, "motion_blur", ["Motion Blur off"])


def test_passes_and_the_image_input(checked):
    res, _ = checked
    _refused(res, "pass_disabled", ["Diffuse Color (use_pass_diffuse_color)", "Set up SSGI", "View Layer > Passes"])
    _warned(res, "image_unlinked", ["'SSGI'", "Image input", "Render Layers > Image"])
    _refused(res, "image_unlinked_transparent", ["Image input", "Transparent", "Render Layers > Image"])


def test_a_warned_render_writes_its_frame_and_says_so_once(checked):
    res, stderr = checked
    r = res["render"]
    assert r["files"] and r["files"][0].endswith("warned.exr"), r
    assert r["shape"] == [36, 64, 4] and r["finite"], r
    rgb = r["rgb"]
    assert 0.05 < sum(rgb) / 3 < 5.0 and not (rgb[0] > 0.9 and rgb[1] < 0.1 and rgb[2] > 0.9), rgb  # not magenta
    assert len(r["warnings"]) == 1 and "motion blur" in r["warnings"][0], r
    assert r["labels"] == ["SSGI: 1 warning (motion_blur)"], r
    assert "1 warning(s): motion blur is on" in r["report"], r["report"]
    after = stderr.split("RENDER-START", 1)[1]
    assert after.count("SSGI: warning: motion blur") == 1, after[-3000:]
