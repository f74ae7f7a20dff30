"""The randomize stage (`cli.py randomize`, the Randomize Room operator's room): one random room from a seed
(ssgi_addon/blender/room.py ``build_room``) in a fresh empty file, optionally saved as a .blend."""
from __future__ import annotations

import os
import sys
from dataclasses import dataclass

import bpy

from ...model.errors import UserError
from ..blender.room import MODES, build_room


@dataclass
class RandomizeConfig:
    """What ``run`` builds; the defaults are those of ``cli.py randomize`` and the Dataset panel."""
    seed: int = 0  # room seed: the same seed gives the same room
    save: str | None = None  # save the scene to this .blend file
    mode: str = "diffuse"  # "diffuse": the seed's diffuse rooms; "artist": docs/artist_rooms.md

    def check(self) -> None:
        if self.mode not in MODES:
            raise UserError(f"--mode {self.mode}: expected one of {', '.join(MODES)}")
        if self.save:
            d = os.path.dirname(os.path.abspath(self.save))
            if not os.path.isdir(d):
                raise UserError(f"--save {self.save}: folder {d} does not exist")
            if not os.access(d, os.W_OK):
                raise UserError(f"--save {self.save}: folder {d} is not writable")


def run(cfg: RandomizeConfig) -> dict:
    """Build the room (module doc); returns seed, objects, camera (and saved: the .blend written)."""
    cfg.check()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    build_room(cfg.seed, scene, cfg.mode)
    out = {"seed": cfg.seed, "mode": cfg.mode, "objects": len(scene.objects), "camera": scene.camera.name}
    if cfg.save:
        path = os.path.abspath(cfg.save)
        bpy.ops.wm.save_as_mainfile(filepath=path, check_existing=False)
        out["saved"] = path
    print(f"room {cfg.seed}: {len(scene.objects)} objects" + (f", saved {out.get('saved')}" if cfg.save else ""),
          file=sys.stderr)
    return out
