"""Bad arguments on real Blender: `bake --ref-samples` below what the reference target needs is refused in
one line (no traceback, nothing written); `render --out` with a known image extension writes that format
(as Blender's -F), and a file without the SSGI node is told about --setup. Renders are 16x9, 1 EEVEE sample."""
from __future__ import annotations

import json
import shutil

from ..conftest import ROOT, clean, run_cli, run_py

FIX = ROOT / "tests" / "fixtures"
EXR_MAGIC, PNG_MAGIC = b"v/1\x01", b"\x89PNG"


def test_bake_with_a_cap_below_the_reference_halves_is_refused_in_one_line(tmp_path):
    out = tmp_path / "data"
    p = run_cli("bake", "--out", str(out), "--count", "1", "--size", "16x9", "--ref-samples", "1", check=False,
                timeout=300)
    err = clean(p.stderr)
    assert p.returncode == 2 and "Traceback" not in err and "TypeError" not in err, err
    (line,) = [l for l in err.splitlines() if "error" in l]
    assert "--ref-samples 1" in line and "at least 2" in line and "--ref-target-db 0" in line, line
    assert not out.exists()
    # the fixed count it points to works with the same cap
    p = run_cli("bake", "--out", str(out), "--count", "1", "--size", "16x9", "--ref-samples", "1",
                "--ref-target-db", "0", "--json", timeout=300)
    assert json.loads(p.stdout)["baked"] == 1


def _scene_copy(tmp_path, fmt: str):
    """The fixture .blend (PNG output) and its model copied into tmp_path, the output format set to ``fmt``."""
    for f in ("ssgi_scene.blend", "ssgi_tiny.pt"):
        shutil.copy(FIX / f, tmp_path / f)
    blend = tmp_path / "ssgi_scene.blend"
    run_py(f'''
import bpy
bpy.ops.wm.open_mainfile(filepath={str(blend)!r})
bpy.context.scene.render.image_settings.file_format = {fmt!r}
bpy.ops.wm.save_mainfile()
''', timeout=120)
    return blend


def test_render_out_extension_chooses_the_format_as_blender_F_does(tmp_path):
    png_scene = FIX / "ssgi_scene.blend"
    exr_scene = _scene_copy(tmp_path, "OPEN_EXR")
    for blend, name, magic, switched in ((png_scene, "a.exr", EXR_MAGIC, "OPEN_EXR"),
                                         (exr_scene, "b.png", PNG_MAGIC, "PNG"),
                                         (png_scene, "c.png", PNG_MAGIC, None),
                                         (exr_scene, "d_#.exr", EXR_MAGIC, None)):
        p = run_cli("render", "--blend", str(blend), "--out", str(tmp_path / name), "--json", timeout=300)
        (f,) = json.loads(p.stdout)["files"]
        assert f.endswith((".exr", ".png")) and open(f, "rb").read(4) == magic, (name, f)
        note = f"--out {tmp_path / name}: writing"
        assert (f"{note} {switched}" in p.stderr) if switched else (note not in p.stderr), p.stderr


def test_render_without_the_ssgi_node_names_the_setup_flag(tmp_path):
    blend = tmp_path / "plain.blend"
    run_py(f'''
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_cube_add()
bpy.ops.object.camera_add(location=(0, -6, 1))
bpy.context.scene.camera = bpy.context.object
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
''', timeout=120)
    p = run_cli("render", "--blend", str(blend), "--out", str(tmp_path / "x.png"), check=False, timeout=300)
    err = clean(p.stderr)
    assert p.returncode == 2 and "Traceback" not in err
    assert "has no SSGI node" in err and "--setup" in err and "Add > SSGI" in err, err
    assert not (tmp_path / "x.png").exists()


def test_every_command_that_takes_a_model_names_a_folder_or_a_text_file_given_as_one(tmp_path):
    """demo, predict, render and fit --init, each given a folder and a text file as the model: exit 2 with one
    line that says what the file is (never torch's weights_only advice, never a traceback), before any work."""
    from ..conftest import ROOT, clean, run_cli
    fix = ROOT / "tests" / "fixtures"
    folder, text = tmp_path / "models", tmp_path / "notes.txt"
    folder.mkdir()
    text.write_text("not a model\n")
    for bad, what in ((folder, "a folder"), (text, "a text file")):
        runs = {
            "demo": ("demo", "--out", str(tmp_path / "demo"), "--model", str(bad), "--size", "16x9"),
            "predict": ("predict", "--model", str(bad), "--input", str(fix / "dataset" / "000000.exr"),
                        "--out", str(tmp_path / "p.exr")),
            "render": ("render", "--blend", str(fix / "ssgi_scene.blend"), "--model", str(bad),
                       "--out", str(tmp_path / "r_####")),
            "fit": ("fit", "--blend", str(fix / "ssgi_scene.blend"), "--out", str(tmp_path / "f.pt"),
                    "--init", str(bad)),
        }
        for name, args in runs.items():
            p = run_cli(*args, check=False, timeout=300)
            err = clean(p.stderr)
            assert p.returncode == 2, (name, what, err[-2000:])
            assert f"{bad}: not an SSGI model checkpoint ({what}" in err, (name, err[-2000:])
            assert "Traceback" not in err and "weights_only" not in err, (name, err[-2000:])
    assert sorted(q.name for q in tmp_path.iterdir()) == ["models", "notes.txt"]  # nothing written
