"""Artist-mode random scenes (``room_params(seed, mode="artist")``): the parameters, as plain data, no bpy.

A seed draws one of three kinds of scene (docs/artist_rooms.md lists every probability and range):

- a **closed** room (6 walls), an **open** room (one or two walls missing, or windows cut into walls) that sky
  and sun light enter, or an **exterior** (ground plane, box buildings, primitives, no walls) under sun and sky,
  the camera at human height;
- Principled BSDF materials with random specular (IOR level) and roughness, metals, glass (transmission 1,
  clear or rough), procedural textures (checker, noise, voronoi, brick, wave) or generated images on the base
  colour;
- lights: lamp objects, emissive meshes (ceiling panels, screens, lamp shades, neon strips, glowing
  objects), or both; some rooms are lit only by emission (no lamp object at all); big area lights (1-3 m);
  worlds: black, a Sky Texture (single/multiple scattering, i.e. Nishita, or Hosek-Wilkie) or an HDRI-like
  procedural gradient with a bright sun disc, with a Sun light in a share of open rooms and exteriors.

The stream is ``random.Random(f"artist-{seed}")`` (str seeds hash with SHA-512: independent of
PYTHONHASHSEED), so artist scene N is not diffuse room N with other materials. room_artist_build.py builds it.
"""
from __future__ import annotations

import colorsys
import math
import random

PREFIX = "ssgi."
SHAPES = ("cube", "cone", "cylinder", "sphere", "monkey")
WALLS = ("floor", "ceiling", "wall_xn", "wall_xp", "wall_yn", "wall_yp")
SIDES = ("wall_xn", "wall_xp", "wall_yn", "wall_yp")
TEXTURES = ("checker", "noise", "voronoi", "brick", "wave", "image")
SKIES = ("SINGLE_SCATTERING", "MULTIPLE_SCATTERING", "HOSEK_WILKIE")
# mean radiance of the upper hemisphere of each sky at strength 1, sun 35 deg up, no sun disc (Cycles,
# equirectangular camera, docs/artist_rooms.md): a sky's strength is irradiance / (pi * this)
SKY_RADIANCE = {"SINGLE_SCATTERING": 3.1, "MULTIPLE_SCATTERING": 5.0, "HOSEK_WILKIE": 0.11}
METALS = ((0.95, 0.93, 0.88), (1.0, 0.78, 0.34), (0.95, 0.64, 0.54), (0.56, 0.57, 0.58), (0.91, 0.92, 0.92))
EMISSION_GAIN = 1.5  # emitted power / a lamp's power for alike light (measured: docs/artist_rooms.md)
CAMERA_CLEARANCE = 0.35
LAMP_CLEARANCE = 1.2
MIN_WALL_GAP = 0.6
PLAZA = 8.0  # exteriors: buildings stand beyond this radius (m) from the origin; camera within 7 m

# probabilities (docs/artist_rooms.md)
P_KIND = (("closed", 0.40), ("open", 0.35), ("exterior", 0.25))
P_LIGHTING = (("lamps", 0.35), ("emission", 0.30), ("mixed", 0.35))  # rooms; exteriors: sun/sky (+ emitters)
P_SUN_OPEN, P_SUN_EXTERIOR = 0.6, 0.85
OVERCAST = 1.5  # an exterior without a Sun light: its sky this much brighter
P_BIG_AREA = 0.3  # of the lamps in a lamp-lit room: one is a 1-3 m area light
P_OBJ = (("dielectric", 0.52), ("metal", 0.22), ("glass", 0.14), ("emissive", 0.12))
P_TEX_OBJ, P_TEX_FLOOR, P_TEX_WALL = 0.3, 0.55, 0.25


def _pick(rng: random.Random, table) -> str:
    x, acc = rng.random(), 0.0
    for name, p in table:
        acc += p
        if x < acc:
            return name
    return table[-1][0]


def colour(rng: random.Random, sat_max: float = 0.9, v_lo: float = 0.15, v_hi: float = 0.9) -> tuple:
    """A colour from dull to saturated (linear RGB, max component <= v_hi); the diffuse rooms' too."""
    h = rng.random()
    s = rng.uniform(0.0, sat_max) if rng.random() < 0.7 else rng.uniform(0.0, 0.15)
    return tuple(round(c, 6) for c in colorsys.hsv_to_rgb(h, s, rng.uniform(v_lo, v_hi)))


def _r(x: float) -> float:
    return round(x, 6)


def texture(rng: random.Random) -> dict:
    """A base-colour texture: type, scale (per metre; tiles of ~0.1-0.5 m show at 240x135), second colour."""
    kind = rng.choice(TEXTURES)
    t = dict(type=kind, colour2=colour(rng, 0.8, 0.1, 0.9))
    t["scale"] = _r({"checker": rng.uniform(1.5, 5.0), "noise": rng.uniform(0.8, 4.0),
                     "voronoi": rng.uniform(1.5, 6.0), "brick": rng.uniform(1.0, 3.0),
                     "wave": rng.uniform(0.5, 2.5), "image": rng.uniform(0.4, 1.5)}[kind])
    if kind == "image":  # a generated tile image: n x n tiles of random shades around the base colour
        t["pattern"] = rng.choice(("tiles", "planks", "grid"))
        t["tiles"] = rng.choice((2, 4, 8))
        t["jitter"] = _r(rng.uniform(0.1, 0.5))
        t["seed"] = rng.randrange(1 << 30)
    if kind == "wave":
        t["distortion"] = _r(rng.uniform(0.0, 6.0))
    return t


def material(rng: random.Random, kind: str, tex_p: float = 0.0) -> dict:
    """A Principled BSDF's settings: kind dielectric|metal|glass|emissive (emission strength set later)."""
    m = dict(kind=kind, base=colour(rng), roughness=_r(rng.uniform(0.15, 1.0)),
             specular=_r(rng.choice((0.5, rng.uniform(0.0, 1.0)))), metallic=0.0, transmission=0.0,
             ior=1.5, coat=0.0, texture=None, emission=None, strength=0.0)
    if kind == "metal":
        m.update(metallic=1.0, base=rng.choice(METALS) if rng.random() < 0.7 else colour(rng, 0.6, 0.5, 0.95),
                 roughness=_r(rng.choice((rng.uniform(0.0, 0.08), rng.uniform(0.1, 0.5)))))
    elif kind == "glass":
        clear = rng.random() < 0.6
        m.update(transmission=1.0, roughness=_r(0.0 if clear else rng.uniform(0.1, 0.4)), specular=0.5,
                 ior=_r(rng.uniform(1.4, 1.6)), base=colour(rng, 0.4, 0.85, 1.0))
    elif kind == "emissive":
        m.update(emission=colour(rng, 0.7, 1.0, 1.0), base=colour(rng, 0.3, 0.5, 0.9), roughness=0.5)
    else:
        if rng.random() < 0.15:
            m["coat"] = _r(rng.uniform(0.3, 1.0))
        if rng.random() < tex_p:
            m["texture"] = texture(rng)
    return m


def bsphere(shape: str, s: float) -> float:
    """Bounding-sphere radius of a unit primitive (spans [-1, 1]) scaled by ``s``; the diffuse rooms' too."""
    return s * {"cube": math.sqrt(3.0), "cone": math.sqrt(2.0), "cylinder": math.sqrt(2.0), "sphere": 1.0,
                "monkey": 1.49, "plane": math.sqrt(2.0)}[shape]


def _dist(a, b) -> float:
    return math.dist(a, b)


def _track(src, dst) -> tuple:
    """Euler XYZ that points an object's -Z from ``src`` toward ``dst``, +Y up (as to_track_quat('-Z','Y'))."""
    dx, dy, dz = (dst[i] - src[i] for i in range(3))
    horiz = math.hypot(dx, dy)
    pitch = math.atan2(horiz, -dz)  # rotation about X: 0 looks straight down
    yaw = math.atan2(dy, dx) - math.pi / 2
    return (_r(pitch), 0.0, _r(yaw))


def _objects(rng, n, cx, cy, spread_x, spread_y, H, size_lo, size_hi, tex_p, name="obj"):
    out = []
    for i in range(n):
        shape = rng.choice(SHAPES)
        size = rng.uniform(size_lo, size_hi)
        sx, sy, sz = size * rng.uniform(0.7, 1.3), size * rng.uniform(0.7, 1.3), size * rng.uniform(0.7, 1.5)
        floating = rng.random() < 0.25
        x, y = cx + rng.uniform(-1, 1) * spread_x, cy + rng.uniform(-1, 1) * spread_y
        if floating:
            rot = tuple(_r(rng.uniform(0, math.tau)) for _ in range(3))
            z = rng.uniform(0.6, max(0.7, H - 0.7))
        else:
            rot = (0.0, 0.0, _r(rng.uniform(0, math.tau)))
            z = sz * (0.984 if shape == "monkey" else 1.0)
        kind = _pick(rng, P_OBJ)
        out.append(dict(name=f"{PREFIX}{name}.{i:02d}.{shape}", shape=shape, location=(_r(x), _r(y), _r(z)),
                        rotation=rot, scale=(_r(sx), _r(sy), _r(sz)), radius=_r(bsphere(shape, max(sx, sy, sz))),
                        material=material(rng, kind, tex_p)))
    return out


def _emitters(rng, W, D, H, n):
    """Emissive fixtures of a room: ceiling panels, screens, lamp shades, neon strips; and the lamp shades'
    metal poles (plain objects)."""
    out, poles = [], []
    for i in range(n):
        kind = rng.choice(("panel", "screen", "shade", "neon"))
        m = material(rng, "emissive")
        nm = f"{PREFIX}emit.{i}.{kind}"
        if kind == "panel":  # a plane just under the ceiling, facing down
            a, b = rng.uniform(0.25, 0.8), rng.uniform(0.2, 0.6)
            loc = (rng.uniform(-0.3, 0.3) * W, rng.uniform(-0.3, 0.3) * D, H - 0.02)
            d = dict(shape="plane", location=loc, rotation=(math.pi, 0.0, _r(rng.uniform(0, math.pi))),
                     scale=(a, b, 1.0), area=4 * a * b)
        elif kind == "screen":  # a plane a few cm before a wall, facing into the room
            side = rng.choice(SIDES)
            a, b = rng.uniform(0.35, 0.9), rng.uniform(0.22, 0.5)
            z = rng.uniform(0.8, min(1.8, H - b - 0.1))
            t = rng.uniform(-0.3, 0.3)
            # parallel to the wall (local x along it, y up), its normal into the room
            loc, rot = {"wall_xn": ((-W / 2 + 0.03, t * D, z), (math.pi / 2, 0.0, math.pi / 2)),
                        "wall_xp": ((W / 2 - 0.03, t * D, z), (math.pi / 2, 0.0, -math.pi / 2)),
                        "wall_yn": ((t * W, -D / 2 + 0.03, z), (math.pi / 2, 0.0, math.pi)),
                        "wall_yp": ((t * W, D / 2 - 0.03, z), (math.pi / 2, 0.0, 0.0))}[side]
            d = dict(shape="plane", location=loc, rotation=rot, scale=(a, b, 1.0), area=4 * a * b, side=side)
            m["base"] = (0.02, 0.02, 0.02)
        elif kind == "shade":  # a lamp shade (open-ended cylinder/cone) on a floor lamp's pole
            r, h = rng.uniform(0.15, 0.3), rng.uniform(0.15, 0.3)
            z = rng.uniform(1.1, min(1.8, H - 0.4))
            x, y = rng.uniform(-0.4, 0.4) * W, rng.uniform(-0.4, 0.4) * D
            d = dict(shape=rng.choice(("tube", "shade")), location=(x, y, z), rotation=(0.0, 0.0, 0.0),
                     scale=(r, r, h), area=2 * math.pi * r * 2 * h)
            pz = (z - h) / 2
            poles.append(dict(name=f"{PREFIX}obj.pole.{i}.cylinder", shape="cylinder", location=(_r(x), _r(y), _r(pz)),
                              rotation=(0.0, 0.0, 0.0), scale=(0.015, 0.015, _r(pz)), radius=_r(pz),
                              material=material(rng, "metal")))
        else:  # a neon strip: a thin tube along a wall, near the ceiling or the floor
            side = rng.choice(SIDES)
            length = rng.uniform(1.0, 0.8 * (W if side in ("wall_yn", "wall_yp") else D))
            rad = rng.uniform(0.012, 0.03)
            z = rng.choice((H - rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.3)))
            along_x = side in ("wall_yn", "wall_yp")
            off = 0.06
            loc = {"wall_xn": (-W / 2 + off, 0.0, z), "wall_xp": (W / 2 - off, 0.0, z),
                   "wall_yn": (0.0, -D / 2 + off, z), "wall_yp": (0.0, D / 2 - off, z)}[side]
            rot = (0.0, math.pi / 2, 0.0) if along_x else (math.pi / 2, 0.0, 0.0)
            d = dict(shape="cylinder", location=loc, rotation=rot, scale=(rad, rad, length / 2),
                     area=2 * math.pi * rad * length, side=side)
            m["emission"] = colour(rng, 1.0, 1.0, 1.0) if rng.random() < 0.5 else m["emission"]
        d.update(name=nm, kind=kind, material=m,
                 location=tuple(_r(v) for v in d["location"]), scale=tuple(_r(v) for v in d["scale"]),
                 rotation=tuple(_r(v) for v in d["rotation"]))
        sx, sy, sz = d["scale"]
        d["radius"] = _r(math.hypot(sx, sy) if d["shape"] == "plane" else math.sqrt(max(sx, sy) ** 2 + sz * sz))
        out.append(d)
    return out, poles


def _set_emission(emitters, power):
    """Share ``power`` (W, as a lamp's) over the emitters: strength = P / (pi * area) per emitter, so that an
    emitter lights the room as a lamp of that power would; neon and screens a bit brighter (small areas)."""
    for e in emitters:
        e["material"]["strength"] = _r(min(400.0, power / len(emitters) / (math.pi * e["area"])))


def artist_params(seed: int) -> dict:
    """Every random choice of artist scene ``seed`` as plain data (deterministic; no bpy)."""
    rng = random.Random(f"artist-{int(seed)}")
    kind = _pick(rng, P_KIND)
    if kind == "exterior":
        return _exterior(rng, int(seed))
    return room_scene(rng, int(seed), kind)


def _artist_wall(rng, wall: str) -> tuple:
    return colour(rng, 0.6, 0.2, 0.85)


def room_scene(rng, seed: int, kind: str, mode: str = "artist", wall_base=_artist_wall, open_style=None,
               tex_wall: float = P_TEX_WALL) -> dict:
    """A closed or open room of the artist kind, drawn from ``rng``; room_interior.py's bright interiors give
    their own ``wall_base(rng, wall)`` (the walls' base colours), ``open_style`` ("windows": no missing wall)
    and ``tex_wall`` (the walls' texture probability)."""
    W, D, H = rng.uniform(3.5, 8.0), rng.uniform(3.5, 8.0), rng.uniform(2.5, 4.0)
    walls = {}
    for w in WALLS:
        tex_p = P_TEX_FLOOR if w == "floor" else tex_wall
        m = material(rng, "dielectric", tex_p)
        m["base"] = wall_base(rng, w)
        if w == "floor" and rng.random() < 0.45:  # a glossy floor
            m["roughness"], m["specular"] = _r(rng.uniform(0.03, 0.3)), _r(rng.uniform(0.4, 1.0))
        walls[w] = dict(material=m, window=None)
    missing = []
    if kind == "open":
        style = open_style or rng.choice(("missing", "windows", "both"))
        sides = rng.sample(SIDES, 2)
        if style in ("missing", "both"):
            missing = sides[:1] if (style == "both" or rng.random() < 0.6) else sides
        if style in ("windows", "both"):
            for s in rng.sample([s for s in SIDES if s not in missing], rng.randint(1, 2)):
                # the window as fractions of the wall's half-extents (u along the wall, v up): wide, not full
                u0 = rng.uniform(-0.8, 0.1)
                v0 = rng.uniform(-0.5, 0.0)
                walls[s]["window"] = (_r(u0), _r(min(0.9, u0 + rng.uniform(0.4, 1.2))), _r(v0),
                                      _r(min(0.85, v0 + rng.uniform(0.6, 1.1))))
        for s in missing:
            del walls[s]
    lighting = _pick(rng, P_LIGHTING)
    sun = None
    if kind == "open" and rng.random() < P_SUN_OPEN and lighting != "emission":
        sun = _sun(rng)
    world = _world(rng, sun) if kind == "open" else dict(type="black")

    objects = _objects(rng, rng.randint(3, 9), rng.uniform(-0.15, 0.15) * W, rng.uniform(-0.15, 0.15) * D,
                       0.3 * W, 0.3 * D, H, 0.18, 0.6, P_TEX_OBJ)
    scale = (W * D + W * H + D * H) / 3.0  # as the diffuse rooms: ~ squared room size
    power = scale * rng.uniform(1.2, 4.0)  # W (lamps) or emitted (emitters); measured: docs/artist_rooms.md
    n_emit = 0 if lighting == "lamps" else rng.randint(1, 3)
    emitters, poles = _emitters(rng, W, D, H, n_emit)
    objects += poles
    glowing = [o for o in objects if o["material"]["kind"] == "emissive"]
    for o in glowing:
        o["area"] = _r(4 * math.pi * (o["radius"] / 1.5) ** 2)
    if lighting == "lamps":  # glowing objects are accents there, the lamps light the room
        for o in glowing:
            o["material"]["strength"] = _r(rng.uniform(0.5, 2.0))
    else:
        _set_emission(emitters + glowing, power * EMISSION_GAIN * (1.0 if lighting == "emission" else 0.5))
    lights = []
    if lighting != "emission":
        lights = _lamps(rng, W, D, H, objects + emitters, power if lighting == "lamps" else power * 0.5)
    if sun is not None:  # the sky and sun add to the room's own lights: dim those
        for li in lights:
            li["energy"] = _r(li["energy"] * 0.5)
    target = _centre(objects, H)
    camera = _room_camera(rng, W, D, H, objects + emitters, target, [li["location"] for li in lights])
    return dict(seed=int(seed), mode=mode, kind=kind, lighting=lighting, size=(W, D, H), walls=walls,
                missing=missing, world=world, sun=sun, objects=objects, emitters=emitters, lights=lights,
                camera=camera)


def _sun(rng) -> dict:
    return dict(elevation=_r(math.radians(rng.uniform(12.0, 65.0))), azimuth=_r(rng.uniform(0, math.tau)),
                energy=_r(rng.uniform(1.0, 3.0)), angle=_r(math.radians(rng.uniform(0.5, 4.0))),
                colour=tuple(_r(c) for c in colorsys.hsv_to_rgb(rng.uniform(0.05, 0.12), rng.uniform(0.0, 0.3), 1.0)))


def _world(rng, sun) -> dict:
    """Sky Texture (Nishita-type or Hosek-Wilkie) or an HDRI-like gradient with a sun disc. ``irradiance``:
    the sky's light on a horizontal surface (W/m^2), so that any sky lights a scene alike."""
    elev = sun["elevation"] if sun else _r(math.radians(rng.uniform(10.0, 60.0)))
    az = sun["azimuth"] if sun else _r(rng.uniform(0, math.tau))
    irr = _r(rng.uniform(0.5, 1.6))
    if rng.random() < 0.6:
        t = rng.choice(SKIES)
        return dict(type="sky", sky=t, elevation=elev, azimuth=az, irradiance=irr,
                    strength=_r(irr / (math.pi * SKY_RADIANCE[t])))
    return dict(type="gradient", zenith=colour(rng, 0.6, 0.4, 1.0), horizon=colour(rng, 0.35, 0.7, 1.0),
                ground=colour(rng, 0.4, 0.1, 0.4), elevation=elev, azimuth=az, irradiance=irr,
                strength=_r(irr / math.pi / 0.8), disc=_r(rng.uniform(50.0, 400.0)),
                disc_size=_r(math.radians(rng.uniform(0.5, 3.0))))


def _lamps(rng, W, D, H, occupied, power) -> list:
    lights = []
    n = rng.randint(1, 3)
    big = rng.random() < P_BIG_AREA
    for i in range(n):
        t = "AREA" if (big and i == 0) else rng.choice(("POINT", "AREA", "SPOT"))
        for _ in range(200):
            p = (rng.uniform(-W / 2 + 0.35, W / 2 - 0.35), rng.uniform(-D / 2 + 0.35, D / 2 - 0.35),
                 rng.uniform(0.55, 0.92) * H)
            if all(_dist(p, o["location"]) > o["radius"] + 0.3 for o in occupied):
                break
        e = power / n ** 0.5
        d = dict(name=f"{PREFIX}light.{i}.{t.lower()}", type=t, location=tuple(_r(v) for v in p),
                 colour=colour(rng, 0.45, 1.0, 1.0), energy=_r(e), radius=_r(rng.uniform(0.05, 0.4)))
        aim = (rng.uniform(-0.3, 0.3) * W, rng.uniform(-0.3, 0.3) * D, 0.0)
        if t == "SPOT":
            d.update(spot_size=_r(math.radians(rng.uniform(60.0, 120.0))), spot_blend=_r(rng.uniform(0.05, 0.5)),
                     energy=_r(e * 1.5))
        elif t == "AREA":
            d["shape"] = rng.choice(("SQUARE", "RECTANGLE", "DISK", "ELLIPSE"))
            d["size"] = _r(rng.uniform(1.0, min(3.0, 0.6 * min(W, D))) if (big and i == 0) else rng.uniform(0.3, 1.4))
            d["size_y"] = _r(d["size"] * rng.uniform(0.4, 1.0)) if d["shape"] in ("RECTANGLE", "ELLIPSE") else d["size"]
            d["energy"] = _r(e * 1.5)
            aim = (p[0] + (aim[0] - p[0]) * 0.5, p[1] + (aim[1] - p[1]) * 0.5, 0.0)
            if big and i == 0:
                d["location"] = (d["location"][0], d["location"][1], _r(H - 0.05))
                aim = (p[0], p[1], 0.0)
        d["rotation"] = _track(d["location"], aim)
        lights.append(d)
    return lights


def _centre(objects, H) -> tuple:
    n = len(objects)
    return (sum(o["location"][0] for o in objects) / n, sum(o["location"][1] for o in objects) / n,
            min(H * 0.45, sum(o["location"][2] for o in objects) / n))


def _camera(rng, p, target, lens_lo=18.0, lens_hi=32.0) -> dict:
    look = (target[0] + rng.uniform(-0.3, 0.3), target[1] + rng.uniform(-0.3, 0.3), target[2] + rng.uniform(-0.2, 0.3))
    return dict(name=f"{PREFIX}camera", location=tuple(_r(v) for v in p), rotation=_track(p, look),
                lens=_r(rng.uniform(lens_lo, lens_hi)))


def _room_camera(rng, W, D, H, occupied, target, lamps) -> dict:
    """Inside the room, outside every object, 1.5 m from what it looks at and (in the first 300 tries) 1.2 m
    from every lamp (a lamp beside the camera blows out the frame)."""
    for k in range(500):
        g = MIN_WALL_GAP
        p = (rng.uniform(-W / 2 + g, W / 2 - g), rng.uniform(-D / 2 + g, D / 2 - g), rng.uniform(0.5, min(2.0, H - g)))
        if (all(_dist(p, o["location"]) > o["radius"] + CAMERA_CLEARANCE for o in occupied) and _dist(p, target) > 1.5
                and (k >= 300 or all(_dist(p, q) > LAMP_CLEARANCE for q in lamps))):
            break
    return _camera(rng, p, target)


def _exterior(rng, seed: int) -> dict:
    """Ground, 3-10 box buildings around a plaza, 2-7 primitives on it, a human-height camera; sun and sky."""
    G = 80.0  # ground plane size (m)
    ground = material(rng, "dielectric", 0.6)
    ground["base"] = colour(rng, 0.35, 0.15, 0.55)
    buildings = []
    for i in range(rng.randint(3, 10)):
        sx, sy, sz = rng.uniform(1.5, 6.0), rng.uniform(1.5, 6.0), rng.uniform(1.5, 10.0)
        # the footprint stays outside the plaza (radius PLAZA), where the camera and the primitives are
        ang, r = rng.uniform(0, math.tau), rng.uniform(PLAZA, 25.0) + math.hypot(sx, sy)
        m = material(rng, "metal" if rng.random() < 0.1 else "dielectric", 0.35)
        if m["kind"] == "dielectric":
            m["base"] = colour(rng, 0.5, 0.2, 0.8)
        buildings.append(dict(name=f"{PREFIX}bldg.{i:02d}.cube", shape="cube",
                              location=(_r(r * math.cos(ang)), _r(r * math.sin(ang)), _r(sz)),
                              rotation=(0.0, 0.0, _r(rng.uniform(0, math.pi))), scale=(_r(sx), _r(sy), _r(sz)),
                              radius=_r(math.sqrt(sx * sx + sy * sy + sz * sz)), material=m))
    objects = _objects(rng, rng.randint(2, 7), 0.0, 0.0, 3.0, 3.0, 2.5, 0.25, 0.8, P_TEX_OBJ)
    sun = _sun(rng) if rng.random() < P_SUN_EXTERIOR else None
    world = _world(rng, sun)
    if sun is None:  # overcast: a brighter sky does the sun's work
        world["irradiance"] = _r(world["irradiance"] * OVERCAST)
        world["strength"] = _r(world["strength"] * OVERCAST)
    glowing = [o for o in objects if o["material"]["kind"] == "emissive"]
    for o in glowing:
        o["area"] = _r(4 * math.pi * (o["radius"] / 1.5) ** 2)
        o["material"]["strength"] = _r(rng.uniform(2.0, 8.0))
    occupied = objects  # buildings stand outside the plaza
    # nearly level: the upper part of the frame shows buildings and sky
    target = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(0.9, 2.0))
    for _ in range(500):
        a, r = rng.uniform(0, math.tau), rng.uniform(3.0, 7.0)
        p = (r * math.cos(a), r * math.sin(a), rng.uniform(1.5, 1.8))
        if all(_dist(p, o["location"]) > o["radius"] + CAMERA_CLEARANCE for o in occupied):
            break
    camera = _camera(rng, p, target, 20.0, 35.0)
    return dict(seed=seed, mode="artist", kind="exterior", lighting="sun" if sun else "sky", size=(G, G, 0.0),
                ground=ground, walls={}, missing=[], world=world, sun=sun, objects=objects + buildings,
                emitters=[], lights=[], camera=camera)
