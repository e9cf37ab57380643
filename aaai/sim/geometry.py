"""Plane geometry of a level spec without physics: floor tiles merged into rectangles, the
missing floor, object footprints."""

from __future__ import annotations

import math
from collections.abc import Sequence

from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.behaviours import STEP_OVER
from aaai.spec.kinds import kind_class

TOLERANCE = 1e-3  # faces that touch do not overlap


class Bounds:
    """What a moving part (a random walker, a bouncing piece) steers clear of: the arena's edge and
    the static solids inside the arena (not zones, not food, not anything that moves). Built from a
    spec alone, so a part's path can be worked out without physics (aaai.spec.behaviours.Bounce.path)
    as the world moves it.

    A random walker keeps to the floor and turns back at the axis-aligned box round any solid's
    footprint (:meth:`blocked`). A bouncing piece goes in three dimensions: it is reflected off the
    face of what stands more than STEP_OVER above its underside there (:meth:`face`, turned
    footprints and their true faces), goes over what does not, falls onto what lies beneath it
    (:meth:`ground`) and rolls round an edge it cuts into (:meth:`push_out`)."""

    def __init__(self, spec: LevelSpec):
        self.half_x, self.half_y = spec.arena_size[0] / 2, spec.arena_size[1] / 2
        self.solids = [
            obj
            for obj in spec.objects
            if not obj.is_edible
            and obj.mass == 0
            and abs(obj.position[0]) < self.half_x
            and abs(obj.position[1]) < self.half_y
            and not getattr(kind_class(obj.kind), "zone", False)
        ]
        self.boxes = [footprint(obj) for obj in self.solids]
        # each solid's centre and the radius of a circle round its footprint: most are passed over at a glance
        self.near = [
            (obj.position[0], obj.position[1], math.hypot(obj.size[0], obj.size[1]) / 2) for obj in self.solids
        ]

    def blocked(self, x: float, y: float, radius: float) -> bool:
        """Would a disc at (x, y) leave the arena or overlap a static solid's footprint box?"""
        half_x, half_y = self.half_x - radius, self.half_y - radius
        if not (-half_x <= x <= half_x and -half_y <= y <= half_y):
            return True
        return any(abs(x - ox) < hx + radius and abs(y - oy) < hy + radius for ox, oy, hx, hy in self.boxes)

    def ground(self, x: float, y: float, bottom: float) -> float:
        """The height of what lies under (x, y) no higher than STEP_OVER above ``bottom``: the highest
        such top of a static solid (a ramp's slope there), else the floor (0)."""
        height = 0.0
        for obj, (cx, cy, round_) in zip(self.solids, self.near):
            if abs(x - cx) > round_ or abs(y - cy) > round_:
                continue
            u, v = local(obj, x, y)
            if abs(u) <= obj.size[0] / 2 and abs(v) <= obj.size[1] / 2:
                top = surface(obj, x, y)
                if height < top <= bottom + STEP_OVER:
                    height = top
        return height

    def face(self, x: float, y: float, z: float, radius: float, height: float) -> tuple[float, float] | None:
        """The outward normal (x, y) of what a ball (centre (x, y, z), ``radius``) runs into: the
        arena's edge, or the face of a static solid whose top there stands higher than ``height`` and
        more than STEP_OVER above the ball's underside over it (a ramp: its full height from beside
        it; from over its slope, the slope, facing down it). None: clear."""
        if x < radius - self.half_x:
            return (1.0, 0.0)
        if x > self.half_x - radius:
            return (-1.0, 0.0)
        if y < radius - self.half_y:
            return (0.0, 1.0)
        if y > self.half_y - radius:
            return (0.0, -1.0)
        for obj, (cx, cy, round_) in zip(self.solids, self.near):
            if abs(x - cx) > round_ + radius or abs(y - cy) > round_ + radius:
                continue
            u, v = local(obj, x, y)
            du, dv = abs(u) - obj.size[0] / 2, abs(v) - obj.size[1] / 2
            off = math.hypot(max(du, 0.0), max(dv, 0.0))
            if off >= radius:
                continue
            underside = z - math.sqrt(radius * radius - off * off)
            # a ramp's side or foot stops it as a wall of the ramp's full height would: it does not roll up one
            top = surface(obj, *nearest(obj, u, v)) if off == 0 else obj.position[2] + obj.size[2] / 2
            if top <= max(height, underside + STEP_OVER):
                continue
            if obj.kind == "ramp" and du < 0 and dv < 0:
                nu, nv = -1.0, 0.0  # on the slope: it faces down the ramp's -x
            elif du > dv:
                nu, nv = math.copysign(1.0, u), 0.0
            else:
                nu, nv = 0.0, math.copysign(1.0, v)
            c, s = math.cos(obj.yaw), math.sin(obj.yaw)
            return (c * nu - s * nv, s * nu + c * nv)
        return None

    def push_out(self, x: float, y: float, z: float, radius: float) -> tuple[float, float, float]:
        """A ball (centre (x, y, z), ``radius``) moved out of the static solids it cuts into, along the
        line from each one's nearest point: off an edge it rolls round, it goes over and down."""
        for obj, (cx, cy, round_) in zip(self.solids, self.near):
            if abs(x - cx) > round_ + radius or abs(y - cy) > round_ + radius:
                continue
            u, v = local(obj, x, y)
            near_x, near_y = nearest(obj, u, v)
            if math.hypot(x - near_x, y - near_y) >= radius:
                continue
            near_z = min(max(z, obj.position[2] - obj.size[2] / 2), surface(obj, near_x, near_y))
            dx, dy, dz = x - near_x, y - near_y, z - near_z
            distance = math.sqrt(dx * dx + dy * dy + dz * dz)
            if 0 < distance < radius:
                k = radius / distance
                x, y, z = near_x + dx * k, near_y + dy * k, near_z + dz * k
        return x, y, z


def nearest(obj: ObjectSpec, u: float, v: float) -> tuple[float, float]:
    """The point (x, y) of an object's footprint nearest the point (u, v) of its own frame."""
    cu, cv = _clamp(u, obj.size[0] / 2), _clamp(v, obj.size[1] / 2)
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    return obj.position[0] + c * cu - s * cv, obj.position[1] + s * cu + c * cv


def _clamp(value: float, half: float) -> float:
    return min(max(value, -half), half)


def local(obj: ObjectSpec, x: float, y: float) -> tuple[float, float]:
    """The point (x, y) in the object's own frame (its centre, turned by its yaw)."""
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    dx, dy = x - obj.position[0], y - obj.position[1]
    return c * dx + s * dy, -s * dx + c * dy


def ramp_height(ramp: ObjectSpec, x: float, y: float) -> float:
    """A ramp's height above its bottom over the point of its footprint nearest (x, y): it rises
    along its own +x from 0 to its full height."""
    u, _ = local(ramp, x, y)
    length = ramp.size[0]
    return ramp.size[2] * min(max((u + length / 2) / length, 0.0), 1.0)


def surface(obj: ObjectSpec, x: float, y: float) -> float:
    """The height of a static solid's top over (x, y) of its footprint: a ramp's slope, or its top."""
    if obj.kind == "ramp":
        return obj.position[2] - obj.size[2] / 2 + ramp_height(obj, x, y)
    return obj.position[2] + obj.size[2] / 2


def merge_tiles(nx: int, ny: int, holes: set[tuple[int, int]]) -> list[tuple[int, int, int, int]]:
    """Covers the present tiles with few rectangles (i0, j0, i1, j1), end-exclusive.

    Each row's runs of present tiles are found, then a run is stretched over the next rows
    while they hold the very same run.
    """
    runs_by_row = []
    for j in range(ny):
        runs, i = [], 0
        while i < nx:
            if (i, j) in holes:
                i += 1
                continue
            start = i
            while i < nx and (i, j) not in holes:
                i += 1
            runs.append((start, i))
        runs_by_row.append(runs)
    rectangles: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}  # (i0, i1) -> first row
    for j in range(ny + 1):
        row = set(runs_by_row[j]) if j < ny else set()
        for run in [r for r in open_runs if r not in row]:
            rectangles.append((run[0], open_runs.pop(run), run[1], j))
        for run in row:
            open_runs.setdefault(run, j)
    return sorted(rectangles, key=lambda r: (r[1], r[0]))


def missing_floor(spec: LevelSpec) -> list[tuple[float, float, float, float]]:
    """The level's holes, pits and trenches as few world rectangles (x0, y0, x1, y1)."""
    if not spec.holes or spec.heightfield is not None:
        return []
    nx, ny = spec.tiles
    tile_x, tile_y = spec.arena_size[0] / nx, spec.arena_size[1] / ny
    present = {(i, j) for i in range(nx) for j in range(ny)} - set(map(tuple, spec.holes))
    left, bottom = -spec.arena_size[0] / 2, -spec.arena_size[1] / 2
    return [
        (left + i0 * tile_x, bottom + j0 * tile_y, left + i1 * tile_x, bottom + j1 * tile_y)
        for i0, j0, i1, j1 in merge_tiles(nx, ny, present)
    ]


Quad = tuple[tuple[float, float], ...]


def corners(obj: ObjectSpec) -> Quad:
    """The four (x, y) corners of an object's footprint (a sphere's or cylinder's bounding square)."""
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    hx, hy = obj.size[0] / 2, obj.size[1] / 2
    x, y = obj.position[0], obj.position[1]
    return tuple((x + u * c - v * s, y + u * s + v * c) for u, v in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)))


def footprints_overlap(a: Sequence[tuple[float, float]], b: Sequence[tuple[float, float]], gap: float = 0.0) -> bool:
    """Separating-axis test of two convex quadrilaterals: closer than ``gap`` (or overlapping by
    more than TOLERANCE when gap is 0)? Plain floats: this runs at every reset, on a few points."""
    margin = gap if gap > 0 else -TOLERANCE
    a = [(float(x), float(y)) for x, y in a]
    b = [(float(x), float(y)) for x, y in b]
    for axis in (0, 1):  # the bounding boxes first: most pairs are far apart
        if max(p[axis] for p in a) + margin <= min(p[axis] for p in b) or max(p[axis] for p in b) + margin <= min(
            p[axis] for p in a
        ):
            return False
    for quad in (a, b):
        for i in range(4):
            (x0, y0), (x1, y1) = quad[i], quad[(i + 1) % 4]
            length = math.hypot(x1 - x0, y1 - y0)
            ax, ay = -(y1 - y0) / length, (x1 - x0) / length
            pa = [x * ax + y * ay for x, y in a]
            pb = [x * ax + y * ay for x, y in b]
            if max(pa) + margin <= min(pb) or max(pb) + margin <= min(pa):
                return False
    return True


def footprint(obj: ObjectSpec) -> tuple[float, float, float, float]:
    """Centre and half extents (x, y) of the axis-aligned box around an object's footprint."""
    cos, sin = abs(math.cos(obj.yaw)), abs(math.sin(obj.yaw))
    half_x = 0.5 * (cos * obj.size[0] + sin * obj.size[1])
    half_y = 0.5 * (sin * obj.size[0] + cos * obj.size[1])
    return obj.position[0], obj.position[1], half_x, half_y


def distance_to_footprint(obj: ObjectSpec, x: float, y: float) -> float:
    """Distance from (x, y) to an object's footprint rectangle (0 inside it)."""
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    dx, dy = x - obj.position[0], y - obj.position[1]
    u, v = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(max(abs(u) - obj.size[0] / 2, 0.0), max(abs(v) - obj.size[1] / 2, 0.0))
