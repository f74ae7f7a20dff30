"""cli.py's argv handling (both entry styles), without starting a subprocess or importing bpy."""


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
