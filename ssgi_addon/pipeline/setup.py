"""Set up SSGI in a scene (the operator) or in a copy of a .blend (``cli.py setup``): one function for both.

    summary = setup(scene, model=None, compiled=False)        # an open scene: the operator
    summary = run(SetupConfig(blend="in.blend", out="out.blend", compiled=True, model="m.pt"))   # cli.py setup

Without ``compiled``: the SSGI node the extension fills at render time (blender/compositor.py ``setup_scene``).
With it: the model as Blender's own compositor nodes (blender/compiled.py ``setup_compiled``), which a plain
render shows without the extension (docs/compiled.md).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from ...model.errors import UserError


def setup(scene, model: str | None = None, compiled: bool = False) -> dict:
    """Set up SSGI in ``scene``: the extension's node, or with ``compiled`` the compiled group of ``model``."""
    if compiled:
        from ...model.cliargs import model_arg
        from ..blender.compiled import setup_compiled
        from ..blender.node import resolve_model
        # (a shipped model's name: its file; none: the node's, the scene's or the shipped default, as Set up SSGI's)
        return setup_compiled(scene, model_arg(model) if model else str(resolve_model(scene, None)))
    from ..blender.compositor import setup_scene
    return setup_scene(scene, model)


@dataclass
class SetupConfig:
    """What ``run`` sets up; the defaults are those of ``cli.py setup``."""
    blend: str  # the .blend file (never written)
    out: str  # the copy to write
    model: str | None = None  # model checkpoint (None: the file's node's or scene's, else the shipped default)
    compiled: bool = False  # the model as compositor nodes, rendered without the extension
    scene: str | None = None  # scene name (None: the file's active scene)

    def check(self) -> None:
        from ..blender.blendfile import check_blend
        src = check_blend(self.blend)
        out = Path(self.out).expanduser()
        if out.suffix.lower() != ".blend":
            raise UserError(f"--out {self.out}: must name a .blend file")
        if out.exists() and out.resolve() == src:
            raise UserError(f"--out {self.out}: is the --blend file itself; name a copy")
        if out.is_dir():
            raise UserError(f"--out {self.out}: is a folder, not a .blend file")
        if self.model and not Path(self.model).expanduser().is_file():
            raise UserError(f"--model {self.model}: no such model file")


def run(cfg: SetupConfig) -> dict:
    """Open the .blend, set SSGI up in its scene, save the copy ``cfg.out`` (the .blend itself is not written)."""
    import bpy

    from ..blender.blendfile import open_blend, pick_scene

    cfg.check()
    open_blend(cfg.blend)
    scene = pick_scene(cfg.blend, cfg.scene)
    info = setup(scene, str(Path(cfg.model).expanduser().resolve()) if cfg.model else None, cfg.compiled)
    out = Path(cfg.out).expanduser().resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(out), copy=True)
    print(f"SSGI setup: wrote {out}" + (" (compiled: renders without the extension)" if cfg.compiled else ""),
          file=sys.stderr)
    return {"out": str(out), "scene": scene.name, "compiled": bool(cfg.compiled),
            **{k: v for k, v in info.items() if k not in ("tree",)}}
