"""Furnished rooms: a walled compound of rooms joined by doorways, furnished with real models and
photographic textures from the installed furniture catalogue (``render/catalog.py``), and a
third-person camera following a runner through them.

``rooms`` draws on the catalogue's ``train`` split and ``rooms_unseen`` on its ``unseen`` split,
so the unseen scenes share no mesh and no texture with anything trained on.  Per seed: which
rooms have a roof (indoor light from the sky only, or sun and shadows), the time of day (day,
dusk or night with glowing fixtures), the floor and wall photographs and their gloss, the
furniture and where it stands (clear of the doorways and of the runner's route along the rooms'
axes), props that slide and spin, and the runner's route.  The camera
trails the runner along its own route (so it passes through the doorways, never the walls),
strafes from side to side, whips round when the runner turns and, after one cut, runs ahead of
it looking back.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np

from .. import catalog, shapes
from ..camera import CameraPath
from ..mesh import Material
from ..scene import Scene, Sky, Sun
from . import common

GRID = 3  # rooms per side
ROOM = 9.0  # metres
WALL_HEIGHT = 3.2
WALL = 0.2  # thickness
DOOR = 2.2  # doorway width
DOOR_CLEARANCE = 1.8  # no furniture this close to a doorway's axis
CORNER_OFFSET = 2.6  # floor props stand this far from the room's axes, the runner's route
CORNER_PROP_M = 1.8  # and are at most this wide
ROUTE_SPREAD = 0.6  # the route passes a room's centre within this distance
KEYS_PER_SECOND = 15  # camera keyframes along the follow path
LIGHTING = {
    "day": (Sun((0.45, 0.8, 0.3), (3.2, 3.0, 2.7)), Sky()),
    "dusk": (Sun((0.85, 0.22, -0.35), (3.6, 1.7, 0.8)), Sky((0.2, 0.22, 0.4), (0.9, 0.55, 0.35), (0.12, 0.09, 0.07))),
    "night": (Sun((0.2, 0.9, 0.35), (0.9, 1.0, 1.4)), Sky((0.06, 0.08, 0.16), (0.1, 0.11, 0.16), (0.03, 0.03, 0.03))),
}
LIGHTING_ODDS = (0.5, 0.3, 0.2)


def build(seed: int, duration: float, start: float, camera: CameraPath | None, particles: bool, animated_light: bool,
          split: str = "train") -> Scene:
    name = "rooms" if split == "train" else f"rooms_{split}"
    b = common.SceneBuilder(name, seed)
    rng = b.rng
    props = catalog.props(split)
    photos = catalog.surface_textures(split)
    lighting = str(rng.choice(list(LIGHTING), p=LIGHTING_ODDS))
    lamp = Material(base_color=(0.3, 0.28, 0.22), emissive=(6.0, 5.0, 3.6) if lighting == "night" else (1.5, 1.3, 0.9),
                    roughness=0.3, name="lamp")
    shell(b, rng, photos, lamp)
    furnish(b, rng, props)
    route = runner_route(rng)
    runner_cloth = Material(base_color_texture=photos[int(rng.integers(len(photos)))], roughness=0.8, name="runner")
    skin = Material(base_color=tuple(rng.uniform(0.35, 0.8, 3)), roughness=0.6, name="runner_skin")
    common.character(b, route, 1.8, runner_cloth, skin, stride=8.0)
    sun, sky = LIGHTING[lighting]
    sun = Sun(sun.direction, sun.color, animated_light)
    cam = camera or follow_camera(rng, route, start, duration)
    return b.build(cam, sun=sun, sky=sky, near=0.05, far=120.0, shadow_radius=20.0)


def room_centre(i: int, j: int) -> np.ndarray:
    return np.array([(i - (GRID - 1) / 2) * ROOM, (j - (GRID - 1) / 2) * ROOM])


def shell(b: common.SceneBuilder, rng: np.random.Generator, photos: list[np.ndarray], lamp: Material) -> None:
    """Floors, walls with a doorway between every two neighbouring rooms, roofs over some rooms,
    ceiling lamps and sagging cables across the open ones."""
    def surface(roughness_range, name):
        return Material(base_color_texture=photos[int(rng.integers(len(photos)))], roughness=float(rng.uniform(*roughness_range)),
                        name=name)

    cable = Material(base_color=(0.04, 0.04, 0.04), roughness=0.6, name="cable")
    for i in range(GRID):
        for j in range(GRID):
            x, z = room_centre(i, j)
            b.add(shapes.plane(ROOM, ROOM, surface((0.1, 0.6), "floor"), uv_scale=float(rng.uniform(1.0, 2.5))),
                  shapes.translate(x, 0.0, z))
            if rng.random() < 0.35:
                b.add(shapes.box((ROOM, 0.2, ROOM), surface((0.5, 0.9), "ceiling"), 2.0), shapes.translate(x, WALL_HEIGHT + 0.1, z))
                b.add(shapes.box((1.4, 0.06, 0.25), lamp), shapes.translate(x, WALL_HEIGHT - 0.05, z))
            else:
                for k in range(2):
                    a = (x - ROOM / 2, WALL_HEIGHT - 0.2, z + rng.uniform(-3, 3))
                    c = (x + ROOM / 2, WALL_HEIGHT - 0.2, z + rng.uniform(-3, 3))
                    b.add(shapes.wire(a, c, 0.012, cable, sag=0.5, pieces=6))
    wall = [surface((0.4, 0.9), "wall") for _ in range(3)]
    for k in range(GRID + 1):  # wall lines at x = const and z = const, doorways in the inner ones
        offset = (k - GRID / 2) * ROOM
        for r in range(GRID):
            centre = (r - (GRID - 1) / 2) * ROOM
            inner = 0 < k < GRID
            pieces = [(centre - ROOM / 2, centre - DOOR / 2), (centre + DOOR / 2, centre + ROOM / 2)] if inner else \
                [(centre - ROOM / 2, centre + ROOM / 2)]
            for lo, hi in pieces:
                length, mid = hi - lo, (lo + hi) / 2
                material = wall[int(rng.integers(len(wall)))]
                b.add(shapes.box((WALL, WALL_HEIGHT, length), material, 2.0), shapes.translate(offset, WALL_HEIGHT / 2, mid))
                b.add(shapes.box((length, WALL_HEIGHT, WALL), material, 2.0), shapes.translate(mid, WALL_HEIGHT / 2, offset))


def furnish(b: common.SceneBuilder, rng: np.random.Generator, props: list[catalog.Prop]) -> None:
    """Furniture against the walls of every room, clear of the doorways, and in the corners of the
    floor (off the runner's route along the room's axes), some of it sliding or spinning."""
    small = [p for p in props if max(p.size[0], p.size[2]) <= CORNER_PROP_M] or props
    fits = [p for p in props if DOOR_CLEARANCE + p.size[0] <= ROOM / 2 - WALL] or small  # between a doorway and a corner
    for i in range(GRID):
        for j in range(GRID):
            x, z = room_centre(i, j)
            for _ in range(int(rng.integers(4, 8))):
                prop = fits[int(rng.integers(len(fits)))]
                side = int(rng.integers(4))
                reach = prop.size[0] / 2  # its width runs along the wall
                along = float(rng.uniform(DOOR_CLEARANCE + reach, ROOM / 2 - WALL - reach)) * rng.choice([-1.0, 1.0])
                back = ROOM / 2 - WALL / 2 - prop.size[2] / 2 - 0.05
                px, pz = [(along, back), (back, along), (along, -back), (-back, along)][side]
                _place(b, prop, shapes.translate(x + px, 0.0, z + pz) @ shapes.rotate_y(180.0 + 90.0 * side))
            for qx, qz in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
                roll = rng.random()
                if roll > 0.6:
                    continue
                prop = small[int(rng.integers(len(small)))]
                cx, cz = x + qx * CORNER_OFFSET, z + qz * CORNER_OFFSET
                if roll < 0.1:
                    motion = partial(_slide, cx, cz, float(rng.uniform(1.0, 3.0)), float(rng.uniform(0, 10)))
                elif roll < 0.2:
                    motion = partial(_spin, cx, cz, float(rng.uniform(60, 240)))
                else:
                    _place(b, prop, shapes.translate(cx, 0.0, cz) @ shapes.rotate_y(rng.uniform(0, 360)))
                    continue
                for mesh in catalog.prop_meshes(prop):
                    b.animate(mesh, motion)


def _place(b: common.SceneBuilder, prop: catalog.Prop, m: np.ndarray) -> None:
    for mesh in catalog.prop_meshes(prop):
        b.add(mesh, m)


def _slide(x: float, z: float, speed: float, phase: float, t: float) -> np.ndarray:
    return shapes.translate(x + 0.8 * math.sin(speed * t / 0.8 + phase), 0.0, z)


def _spin(x: float, z: float, degrees_per_second: float, t: float) -> np.ndarray:
    return shapes.translate(x, 0.0, z) @ shapes.rotate_y(degrees_per_second * t)


def runner_route(rng: np.random.Generator, rooms: int = 16):
    """A run from room to room through the doorways, never straight back into the room it came
    from: ``path(t) -> (position, heading)`` at a constant speed; before t = 0 it stands at the
    start, after the last room at the end."""
    i, j = int(rng.integers(GRID)), int(rng.integers(GRID))
    points, came_from = [room_centre(i, j) + rng.uniform(-ROUTE_SPREAD, ROUTE_SPREAD, 2)], None
    for _ in range(rooms):
        steps = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)) if 0 <= i + di < GRID and 0 <= j + dj < GRID]
        steps = [r for r in steps if r != came_from] or steps
        came_from, (i, j) = (i, j), steps[int(rng.integers(len(steps)))]
        door = (room_centre(*came_from) + room_centre(i, j)) / 2
        points += [door, room_centre(i, j) + rng.uniform(-ROUTE_SPREAD, ROUTE_SPREAD, 2)]
    points = np.array(points)
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    ends = np.concatenate([[0.0], np.cumsum(lengths)])
    speed = float(rng.uniform(2.5, 4.5))  # running
    head_start = 5.0  # metres: the trailing camera starts on the route too

    def path(t: float):
        s = float(np.clip(head_start + speed * t, 0.0, ends[-1]))
        k = min(int(np.searchsorted(ends, s, side="right")) - 1, len(lengths) - 1)
        d = (points[k + 1] - points[k]) / max(lengths[k], 1e-9)
        p = points[k] + d * (s - ends[k])
        return np.array([p[0], 0.0, p[1]]), math.degrees(math.atan2(d[0], d[1]))

    return path


def follow_camera(rng: np.random.Generator, route, start: float, duration: float) -> CameraPath:
    """Trail the runner along its route at shoulder height, strafing; after one cut, lead it,
    looking back at it.  Both stay on the route, so the camera passes through the doorways."""
    lag = float(rng.uniform(0.7, 1.1))  # seconds behind (then ahead) on the route
    strafe, strafe_rate = float(rng.uniform(0.3, 0.7)), float(rng.uniform(0.8, 1.6))
    cut_at = start + duration * float(rng.uniform(0.55, 0.75))
    points = []
    for t in np.arange(start, start + duration + 1.0 / KEYS_PER_SECOND, 1.0 / KEYS_PER_SECOND):
        runner, _ = route(t)
        camera_at, heading = route(t - lag if t < cut_at else t + lag)
        side = np.array([math.cos(math.radians(heading)), 0.0, -math.sin(math.radians(heading))])
        pos = camera_at + np.array([0.0, 1.7 if t < cut_at else 1.4, 0.0]) + side * strafe * math.sin(strafe_rate * t)
        look = runner + np.array([0.0, 1.2, 0.0])
        points.append((t, pos, look, bool(points) and t >= cut_at and points[-1][0] < cut_at))
    return common.keyframes(points, float(rng.uniform(65, 80)))


build_unseen = partial(build, split="unseen")
