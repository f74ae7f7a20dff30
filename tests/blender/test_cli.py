"""The command line: both entry styles parse, every subcommand has --help, bad arguments name the argument."""
import json

from ..conftest import run_cli, run_py


def test_info_json_reports_versions():
    p = run_cli("info", "--json")
    d = json.loads(p.stdout)
    assert d["ok"] is True
    assert d["blender"].startswith("5.0")
    assert d["torch"] is not None
    assert d["default_inputs"] == "albedo,normal,depth,direct,lit"


def test_every_subcommand_has_help():
    import cli
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    names = list(sub.choices)
    assert "info" in names
    for name in names:
        p = run_cli(name, "--help")
        assert "usage:" in p.stdout and name in p.stdout, name


def test_unknown_subcommand_exits_nonzero_and_names_it():
    p = run_cli("no-such-thing", check=False)
    assert p.returncode != 0
    assert "no-such-thing" in p.stderr


def test_bpy_module_is_not_a_blender_binary():
    p = run_py("import bpy\nprint('binary' if cli.in_blender_binary() else 'module', bpy.app.module)")
    assert p.stdout.split()[-2:] == ["module", "True"]


def test_no_subcommand_exits_2_and_names_it():
    p = run_cli(check=False)
    assert p.returncode == 2 and "SUBCOMMAND" in p.stderr


def test_help_lists_the_foundation_subcommands():
    p = run_cli("--help")
    for name in ("info", "demo"):
        assert name in p.stdout


_OPEN_BLEND = r'''
import json, sys
from pathlib import Path
import bpy
from ssgi.model.errors import UserError
from ssgi.ssgi_addon.blender import blendfile
d = Path(sys.argv[1])
(d / "junk.blend").write_bytes(b"BLENDER-v500 but not really" * 10)
(d / "folder.blend").mkdir()
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.scene.name = "Shot"
bpy.ops.wm.save_as_mainfile(filepath=str(d / "good.blend"))
bpy.ops.wm.read_factory_settings(use_empty=True)
out = {}
for name, call in (("missing", lambda: blendfile.open_blend(d / "gone.blend")),
                   ("folder", lambda: blendfile.open_blend(d / "folder.blend")),
                   ("junk", lambda: blendfile.open_blend(d / "junk.blend", arg="--scenes")),
                   ("no_arg", lambda: blendfile.open_blend(d / "junk.blend", arg=None)),
                   ("good", lambda: blendfile.open_blend(d / "good.blend").name),
                   ("scene", lambda: blendfile.pick_scene(d / "good.blend", "Nope").name),
                   ("scene_ok", lambda: blendfile.pick_scene(d / "good.blend", "Shot").name)):
    try:
        out[name] = ["ok", call()]
    except UserError as e:
        out[name] = ["error", str(e)]
print("JSON" + json.dumps(out))
'''


def test_open_blend_errors_name_the_file_and_the_fault(tmp_path):
    """ssgi_addon/blendfile.py, the one way fit, render and report open a user's .blend."""
    r = json.loads(run_py(_OPEN_BLEND, str(tmp_path), timeout=300).stdout.split("JSON", 1)[1])
    assert r["missing"] == ["error", f"--blend {tmp_path / 'gone.blend'}: no such .blend file"]
    assert r["folder"] == ["error", f"--blend {tmp_path / 'folder.blend'}: is a folder, not a .blend file"]
    kind, msg = r["junk"]
    assert kind == "error" and msg.startswith(f"--scenes {tmp_path / 'junk.blend'}: not a readable .blend file")
    assert "Blender could not open it" in msg
    kind, msg = r["no_arg"]
    assert kind == "error" and msg.startswith(f"{tmp_path / 'junk.blend'}: not a readable .blend file")
    assert r["good"] == ["ok", "Shot"]
    assert r["scene"] == ["error", f"--scene Nope: no such scene in {tmp_path / 'good.blend'}; scenes: Shot"]
    assert r["scene_ok"] == ["ok", "Shot"]


def test_render_refuses_a_bad_blend_with_exit_2(tmp_path):
    junk = tmp_path / "junk.blend"
    junk.write_bytes(b"not a blend file at all")
    p = run_cli("render", "--blend", str(junk), check=False, timeout=300)
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr[-2000:]
    assert f"--blend {junk}: not a readable .blend file" in p.stderr
    p = run_cli("render", "--blend", str(tmp_path), check=False, timeout=300)
    assert p.returncode == 2 and f"--blend {tmp_path}: is a folder" in p.stderr


_USES_CONFTEST = "from tests import conftest; conftest.run_py('pass'); conftest.run_cli('--help')"


def test_test_sessions_remove_their_blender_user_folders(tmp_path):
    """tests/conftest.py's temporary Blender user folders (the session's and each run_py/run_cli's) are gone
    when the process that made them exits; a folder of the same prefix that it did not make is left alone;
    SSGI_KEEP_TEST_USER=1 keeps them."""
    import os
    import subprocess
    import sys

    from ..conftest import ROOT
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    foreign = tmp / "ssgi-test-user-not-ours"
    foreign.mkdir()
    env = dict(os.environ, TMPDIR=str(tmp))
    env.pop("SSGI_KEEP_TEST_USER", None)
    for keep, left in ((None, 1), ("1", 4)):  # 3 kept: the process's own, run_py's and run_cli's
        if keep:
            env["SSGI_KEEP_TEST_USER"] = keep
        p = subprocess.run([sys.executable, "-c", _USES_CONFTEST], cwd=ROOT, env=env, capture_output=True,
                           text=True, timeout=300)
        assert p.returncode == 0, p.stderr[-3000:]
        names = sorted(x.name for x in tmp.iterdir() if x.name.startswith("ssgi-test-user-"))
        assert len(names) == left and foreign.name in names, names
