"""Interior-mode random scenes (``room_params(seed, mode="interior")``): bright lived-in rooms, as plain data, no bpy.

The artist rooms (room_artist.py) paint walls any colour of value 0.2-0.85 and the diffuse rooms 0.2-0.85 too;
the most common real rooms are white, off-white and beige plaster, whose bounce light is several times brighter
(a wall of albedo 0.8 returns 0.8 of what it gets, one of 0.4 half that, and the multiple bounces compound).
The shipped model lit the artist test set's beige closed room at 0.49x the reference (docs/artist_rooms.md):
nothing in its training showed a closed room this bright. An interior is an artist room (materials, objects,
lamps and emitters, glossy floors as room_artist.py draws them) with:
- kind: closed (65 %) or open with one or two windows onto a sky (35 %; no wall missing: a room, not a stage);
- walls: painted plaster, 75 % warm neutrals (hue 0.06-0.15, saturation 0-0.3, value 0.5-0.9), else any hue at
  saturation 0-0.15, value 0.55-0.9; the ceiling white (value 0.72-0.9, saturation <= 0.05); the floor as the
  artist rooms' walls (wood, tiles, carpet: any colour, value 0.15-0.7); walls textured in 10 % (artist: 25 %);
- lights: the artist rooms' lamps / emitters / both at the same power (measured on 6 interiors at 0.6x that
  power: mean reference 0.19 against the artist rooms' 0.33, so the power stays; docs/artist_rooms.md).
The stream is ``random.Random(f"interior-{seed}")``: interior N is neither artist scene N nor studio N.
room_artist_build.py builds it (it is an artist room).
"""
from __future__ import annotations

import colorsys
import random

from .room_artist import _pick, _r, colour, room_scene

P_KIND = (("closed", 0.65), ("open", 0.35))
P_WARM, P_TEX_WALL = 0.75, 0.10


def wall_base(rng, wall: str) -> tuple:
    """The base colour of one wall, the ceiling or the floor of an interior (linear RGB)."""
    if wall == "floor":
        return colour(rng, 0.6, 0.15, 0.7)
    if wall == "ceiling":
        h, s, v = rng.uniform(0.06, 0.15), rng.uniform(0.0, 0.05), rng.uniform(0.72, 0.9)
    elif rng.random() < P_WARM:
        h, s, v = rng.uniform(0.06, 0.15), rng.uniform(0.0, 0.3), rng.uniform(0.5, 0.9)
    else:
        h, s, v = rng.random(), rng.uniform(0.0, 0.15), rng.uniform(0.55, 0.9)
    return tuple(_r(c) for c in colorsys.hsv_to_rgb(h, s, v))


def interior_params(seed: int) -> dict:
    """Every random choice of interior ``seed`` as plain data (deterministic; no bpy)."""
    rng = random.Random(f"interior-{int(seed)}")
    kind = _pick(rng, P_KIND)
    return room_scene(rng, int(seed), kind, mode="interior", wall_base=wall_base, open_style="windows",
                      tex_wall=P_TEX_WALL)
