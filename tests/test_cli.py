"""The command line: both entry styles parse, every subcommand has --help, bad arguments name the argument."""
import json

from .conftest import run_cli, run_py


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


def test_blender_binary_style_argv():
    """`blender --background --python cli.py -- info` passes only what follows `--` to the parser."""
    import sys

    import cli
    old = sys.argv
    try:
        sys.argv = ["blender", "--background", "--python", "cli.py", "--", "info", "--json"]
        assert cli._argv() == ["info", "--json"]
    finally:
        sys.argv = old


def test_argv_forms():
    import sys

    import cli
    old = sys.argv
    try:
        for argv, want in ((["cli.py", "info", "--json"], ["info", "--json"]),
                           (["blender", "-b", "--python", "cli.py"], []),  # no `--`: Blender's own args only
                           (["/opt/blender/blender", "--background", "x.blend", "--python", "cli.py", "--", "demo", "--help"],
                            ["demo", "--help"])):
            sys.argv = argv
            assert cli._argv() == want, argv
    finally:
        sys.argv = old


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
