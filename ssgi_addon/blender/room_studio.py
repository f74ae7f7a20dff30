"""Studio-mode random scenes (``room_params(seed, mode="studio")``): the parameters, as plain data, no bpy.

A product or portrait studio: a cyclorama (a floor curving up into a back wall, no side walls, no ceiling) in a
dark stage, lit by big softboxes. The artist rooms (room_artist.py) are closed or open rooms and exteriors; no
training scene there is an open, dark stage lit by a few big lights, and the shipped model trained on them
added a closed room's bounce light to the artist test set's studio (1.32-1.40x too bright, docs/artist_rooms.md).

Each seed draws (docs/artist_rooms.md, "Studio mode", lists every probability and range):
- the cyclorama: 4-12 m wide, a 0.4-2.5 m cove up to a 3-6 m back wall; white or grey (75 %) or coloured
  paper; matte or semi-glossy, 20 % a glossy floor; in 35 % of the scenes one or two side flags (tall boards,
  black or white) beside the set; the camera sees past the cyclorama's edges into the dark stage in a share of
  the frames (wide lenses, narrow cycloramas);
- 1-5 objects on or above the floor near the set's centre, on a pedestal in 30 %: materials as the artist
  rooms' with more metal and glass (P_OBJ);
- lights: a key softbox (area light, 0.8-3 m, 2-5 m from the subject), then up to three of fill (area 0.5-2 m),
  rim (spot or area behind the subject) and background (a spot or area aimed at the back wall); in 20 % the key
  is an emissive LED panel mesh instead; power grows with the distance squared (energy = d^2 x density);
- the world: black (50 %), a dim uniform grey or tint (35 %, 0.01-0.08), or a dim coloured backdrop (15 %,
  up to 0.25).
The stream is ``random.Random(f"studio-{seed}")``: studio scene N is neither diffuse room N nor artist scene N.
room_artist_build.py builds it.
"""
from __future__ import annotations

import math
import random

from .room_artist import (PREFIX, SHAPES, _dist, _pick, _r, _track, bsphere, colour, material)

P_OBJ = (("dielectric", 0.42), ("metal", 0.30), ("glass", 0.20), ("emissive", 0.08))
P_WORLD = (("black", 0.50), ("dim", 0.35), ("backdrop", 0.15))
P_FLAGS, P_PEDESTAL, P_GLOSSY_FLOOR, P_LED_KEY, P_TEX_OBJ = 0.35, 0.30, 0.20, 0.20, 0.25
EXTRA_LIGHTS = ("fill", "rim", "background")


def _cyc_material(rng) -> dict:
    m = material(rng, "dielectric")
    if rng.random() < 0.75:  # white or grey paper
        v = rng.uniform(0.35, 0.88)
        m["base"] = tuple(_r(v * rng.uniform(0.97, 1.03)) for _ in range(3))
    else:
        m["base"] = colour(rng, 0.7, 0.2, 0.8)
    m["roughness"] = _r(rng.uniform(0.45, 1.0))
    return m


def _objects(rng, n, floor_top) -> list:
    out = []
    for i in range(n):
        shape = rng.choice(SHAPES)
        size = rng.uniform(0.12, 0.55)
        sx, sy, sz = size * rng.uniform(0.7, 1.3), size * rng.uniform(0.7, 1.3), size * rng.uniform(0.7, 1.5)
        for _ in range(100):  # not inside another object
            x, y = rng.uniform(-1.3, 1.3), rng.uniform(-0.9, 0.9)
            if all(math.hypot(x - o["location"][0], y - o["location"][1]) > o["radius"] + size for o in out):
                break
        floating = rng.random() < 0.15
        if floating:
            rot = tuple(_r(rng.uniform(0, math.tau)) for _ in range(3))
            z = floor_top + rng.uniform(0.5, 1.5)
        else:
            rot = (0.0, 0.0, _r(rng.uniform(0, math.tau)))
            z = floor_top + sz * (0.984 if shape == "monkey" else 1.0)
        out.append(dict(name=f"{PREFIX}obj.{i:02d}.{shape}", shape=shape, location=(_r(x), _r(y), _r(z)),
                        rotation=rot, scale=(_r(sx), _r(sy), _r(sz)), radius=_r(bsphere(shape, max(sx, sy, sz))),
                        material=material(rng, _pick(rng, P_OBJ), P_TEX_OBJ)))
    return out


def _light(rng, role: str, i: int, target, back_y: float, height: float) -> dict:
    """One studio light of ``role`` (key, fill, rim, background), aimed; energy = distance^2 x density."""
    tx, ty, tz = target
    if role == "key":
        az, d, big = rng.uniform(-2.4, -0.7), rng.uniform(2.0, 5.0), True
    elif role == "fill":
        az, d, big = rng.choice((rng.uniform(-2.6, -1.9), rng.uniform(-1.2, -0.5))), rng.uniform(2.0, 5.0), False
    elif role == "rim":
        az, d, big = rng.uniform(0.4, 2.7), rng.uniform(1.5, 3.5), False
    else:  # background: from in front of the set, onto the back wall
        az, d, big = rng.uniform(-2.2, -0.9), rng.uniform(1.0, 3.0), False
    p = (tx + d * math.cos(az), ty + d * math.sin(az), rng.uniform(0.6, min(4.0, height - 0.3)))
    aim = (tx, back_y, rng.uniform(0.8, 2.0)) if role == "background" else target
    dist = _dist(p, aim)
    density = {"key": rng.uniform(3.0, 12.0), "fill": rng.uniform(0.8, 4.0), "rim": rng.uniform(2.0, 8.0),
               "background": rng.uniform(1.0, 6.0)}[role]
    t = "AREA" if role in ("key", "fill") else rng.choice(("SPOT", "AREA", "POINT"))
    li = dict(name=f"{PREFIX}light.{i}.{role}.{t.lower()}", type=t, location=tuple(_r(v) for v in p),
              colour=colour(rng, 0.25, 1.0, 1.0) if rng.random() < 0.3 else (1.0, 1.0, 1.0),
              energy=_r(dist * dist * density), radius=_r(rng.uniform(0.05, 0.3)), role=role)
    if t == "AREA":
        li["shape"] = rng.choice(("SQUARE", "RECTANGLE", "DISK", "ELLIPSE"))
        li["size"] = _r(rng.uniform(0.8, 3.0) if big else rng.uniform(0.5, 2.0))
        li["size_y"] = _r(li["size"] * rng.uniform(0.4, 1.0)) if li["shape"] in ("RECTANGLE", "ELLIPSE") else li["size"]
    elif t == "SPOT":
        li.update(spot_size=_r(math.radians(rng.uniform(25.0, 80.0))), spot_blend=_r(rng.uniform(0.1, 0.6)))
        li["energy"] = _r(li["energy"] * 0.6)
    li["rotation"] = _track(li["location"], aim)
    return li


def _led_panel(rng, key: dict) -> dict:
    """An emissive LED panel (a plane mesh) where the key light would stand, facing the subject, as bright as
    the key (strength = energy / (pi * area), as room_artist._set_emission)."""
    a, b = rng.uniform(0.3, 0.9), rng.uniform(0.25, 0.7)
    m = material(rng, "emissive")
    m["emission"] = colour(rng, 0.3, 1.0, 1.0)
    m["strength"] = _r(min(400.0, key["energy"] / (math.pi * 4 * a * b)))
    return dict(name=f"{PREFIX}emit.0.panel", kind="panel", shape="plane", location=key["location"],
                rotation=key["rotation"], scale=(_r(a), _r(b), 1.0), area=_r(4 * a * b),
                radius=_r(math.hypot(a, b)), material=m)


def studio_params(seed: int) -> dict:
    """Every random choice of studio scene ``seed`` as plain data (deterministic; no bpy)."""
    rng = random.Random(f"studio-{int(seed)}")
    width, radius, height = rng.uniform(4.0, 12.0), rng.uniform(0.4, 2.5), rng.uniform(3.0, 6.0)
    back = rng.uniform(1.2, 3.0)  # the back wall's y; the cove starts at back - radius
    front = -rng.uniform(4.0, 9.0)  # the floor's front edge (behind the camera, or in view)
    cyc = _cyc_material(rng)
    if rng.random() < P_GLOSSY_FLOOR:
        cyc["roughness"], cyc["specular"] = _r(rng.uniform(0.05, 0.3)), _r(rng.uniform(0.4, 1.0))
    cyclorama = dict(name=f"{PREFIX}room.cyclorama", width=_r(width), radius=_r(radius), height=_r(height),
                     back=_r(back), front=_r(front), material=cyc)
    flags = []
    if rng.random() < P_FLAGS:
        for side in rng.sample((-1, 1), rng.randint(1, 2)):
            m = material(rng, "dielectric")
            m["base"] = (0.02, 0.02, 0.02) if rng.random() < 0.5 else (0.85, 0.85, 0.85)
            m["roughness"] = 1.0
            h, w = rng.uniform(1.8, 3.0), rng.uniform(0.8, 1.6)
            x, y = side * rng.uniform(1.8, 3.5), rng.uniform(-1.5, 0.8)
            flags.append(dict(name=f"{PREFIX}obj.flag.{'l' if side < 0 else 'r'}.plane", shape="plane",
                              location=(_r(x), _r(y), _r(h / 2)),
                              rotation=(_r(math.pi / 2), 0.0, _r(math.pi / 2 + side * rng.uniform(0.2, 0.7))),
                              scale=(_r(w / 2), _r(h / 2), 1.0), radius=_r(math.hypot(w, h) / 2), material=m))
    floor_top = 0.0
    objects = []
    if rng.random() < P_PEDESTAL:
        ph = rng.uniform(0.05, 0.6)
        m = material(rng, "dielectric")
        objects.append(dict(name=f"{PREFIX}obj.pedestal.cube", shape="cube", location=(0.0, 0.0, _r(ph / 2)),
                            rotation=(0.0, 0.0, _r(rng.uniform(0, math.pi))),
                            scale=(_r(rng.uniform(0.8, 1.6)), _r(rng.uniform(0.6, 1.1)), _r(ph / 2)),
                            radius=_r(math.sqrt(2.6 ** 2 + 1.2 ** 2 + ph ** 2) / 2), material=m))
        floor_top = ph
    objects += _objects(rng, rng.randint(1, 5), floor_top)
    props = objects[1:] if floor_top else objects
    n = len(props)
    target = (sum(o["location"][0] for o in props) / n, sum(o["location"][1] for o in props) / n,
              min(1.5, sum(o["location"][2] for o in props) / n))
    roles = ["key"] + rng.sample(EXTRA_LIGHTS, rng.randint(0, 3))
    lights = [_light(rng, r, i, target, back, height) for i, r in enumerate(roles)]
    emitters = []
    if rng.random() < P_LED_KEY:
        emitters.append(_led_panel(rng, lights.pop(0)))
    w = _pick(rng, P_WORLD)
    if w == "black":
        world = dict(type="black")
    else:
        world = dict(type="colour", colour=colour(rng, 0.15 if w == "dim" else 0.7, 1.0, 1.0),
                     strength=_r(rng.uniform(0.01, 0.08) if w == "dim" else rng.uniform(0.05, 0.25)))
    # the camera: in front of the set, 2.5-7 m from the subject, 0.3-2.2 m high, outside every object
    occupied = objects + flags
    for _ in range(500):
        az, d = rng.uniform(-math.pi / 2 - 0.7, -math.pi / 2 + 0.7), rng.uniform(2.5, 7.0)
        p = (target[0] + d * math.cos(az), target[1] + d * math.sin(az), rng.uniform(0.3, 2.2))
        if all(_dist(p, o["location"]) > o["radius"] + 0.35 for o in occupied):
            break
    look = (target[0] + rng.uniform(-0.2, 0.2), target[1] + rng.uniform(-0.2, 0.2), target[2] + rng.uniform(-0.1, 0.3))
    camera = dict(name=f"{PREFIX}camera", location=tuple(_r(v) for v in p), rotation=_track(p, look),
                  lens=_r(rng.uniform(24.0, 70.0)))
    return dict(seed=int(seed), mode="studio", kind="studio", lighting="emission" if emitters and not lights else
                "lamps" if not emitters else "mixed", size=(_r(width), _r(back - front), _r(height)), walls={},
                missing=[], cyclorama=cyclorama, world=world, sun=None, objects=objects + flags, emitters=emitters,
                lights=lights, camera=camera)
