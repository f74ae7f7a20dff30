"""Render SSGI frames on a render farm with Blender itself: run by a worker as

    blender -b shot.blend -s 1 -e 24 -P <extension folder>/farm_render.py
    blender -b shot.blend -P <extension folder>/farm_render.py -- --frames 1-24

(``-o`` before ``-P`` sets the output path, as for any Blender render.) It renders the frames through the SSGI node
with the scene's own settings and writes them where the scene's output path says; the exit status is 0 when every
frame is written, 2 for a scene it cannot render (one line on stderr says why), 1 for any other failure. Frames
split among workers equal one machine's run. ssgi_addon/pipeline/farm.py does the work.
"""
import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))


def _package():
    """The SSGI package: the extension as Blender loaded it (bl_ext.<repository>.ssgi, or ssgi from a checkout),
    else this folder loaded as ``ssgi``."""
    init = os.path.join(_HERE, "__init__.py")
    for name, mod in list(sys.modules.items()):
        f = getattr(mod, "__file__", None)
        if f and os.path.abspath(f) == init and name.split(".")[-1] == "ssgi":
            return mod
    sys.path.insert(0, _HERE)
    import cli
    return cli.load_package()


if __name__ == "__main__":
    import importlib
    farm = importlib.import_module(_package().__name__ + ".ssgi_addon.pipeline.farm")
    sys.exit(farm.main())
