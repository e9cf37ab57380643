"""Plane geometry of a level spec without physics: floor tiles merged into rectangles, the
missing floor, object footprints."""

from __future__ import annotations

import math
from collections.abc import Sequence

from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.kinds import kind_class

TOLERANCE = 1e-3  # faces that touch do not overlap


class Bounds:
    """What a moving part (a random walker, a bouncing piece) steers clear of: the arena's edge and
    the axis-aligned boxes round the footprints of the static solids inside the arena (not zones,
    not food, not anything that moves). Built from a spec alone, so a part's path can be worked out
    without physics (aaai.spec.behaviours.Bounce.path, given its ``blocked``) as the world moves it."""

    def __init__(self, spec: LevelSpec):
        self.half_x, self.half_y = spec.arena_size[0] / 2, spec.arena_size[1] / 2
        self.boxes = [
            footprint(obj)
            for obj in spec.objects
            if not obj.is_edible
            and obj.mass == 0
            and abs(obj.position[0]) < self.half_x
            and abs(obj.position[1]) < self.half_y
            and not getattr(kind_class(obj.kind), "zone", False)
        ]

    def blocked(self, x: float, y: float, radius: float) -> bool:
        """Would a disc at (x, y) leave the arena or overlap a static solid's footprint box?"""
        half_x, half_y = self.half_x - radius, self.half_y - radius
        if not (-half_x <= x <= half_x and -half_y <= y <= half_y):
            return True
        return any(abs(x - ox) < hx + radius and abs(y - oy) < hy + radius for ox, oy, hx, hy in self.boxes)


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
