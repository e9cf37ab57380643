"""Solvability checks of a LevelSpec, without physics.

A generated level must have: no two solid objects overlapping; the agent's start and every
food piece inside the arena, on solid ground and clear of solids; every food piece reachable
by a body of the agent's footprint. Reachability is a search on an occupancy grid of the
arena: solids and holes (missing floor tiles: holes, pits, trenches) are blocked, sinking
pillars and sector doors are passable (a pillar ends flush with the floor; a door is open
until the agent has gone through it), and a level's ``bridge`` rectangle (where
the L10 plank lands when pushed over) is floor again. The newer kinds (aaai.spec.kinds): a kind built of
parts (a tunnel's arch, an L block) is checked part by part (``pieces``), so the body walks through
a tunnel and food may lie in a U; a ramp is walkable up to RAMP_WALKABLE_HEIGHT and an obstacle
above it, and food may rest on its slope (``ramp_clearance``); a death zone and bad food are blocked
(the body keeps clear of them); a hot zone is walkable (the reference controller avoids it by cost).
An agent's start on a ledge (an imported Animal-AI start on a dividing wall, :func:`start_ledge`) is
clear when the body stands on it and floor lies next to it; the body steps down from it to any side
and never climbs back, so what it reaches is what lies in the regions it steps down into.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

import cv2
import numpy as np

from aaai.agent.urdf_writer import HEAD_RADIUS
from aaai.sim.geometry import TOLERANCE, Bounds, corners, footprints_overlap, local, ramp_height
from aaai.spec import LevelSpec, ObjectSpec
from aaai.spec.behaviours import PATH_EVERY, REGISTRY, behaviour_class
from aaai.spec.kinds import REGISTRY as REGISTRY_KINDS
from aaai.spec.kinds import SOLID_KINDS, kind_class

GRID = 0.5  # occupancy grid cell, units
# The footprint a walking body needs: the resting X reaches 4.5 from the head's centre and the
# trot's feet sweep out to about 5, so a passage must be wider than 10 for the body to walk
# through it without a foot touching a wall (a wall touched costs 1).
FOOTPRINT_RADIUS = 5.0
# Where the head can be to eat: the same places. A body that leans closer to a wall to reach food
# lying against it (with the X's front feet 3.7 ahead, it could bring the head that close) touches
# the wall with a sweeping foot on the way, so food must be reachable from the walking region.
REACH_CLEARANCE = FOOTPRINT_RADIUS
# The highest a piece of food's bottom may lie for the head to touch it: the head's centre rides 1.8
# to 2.3 high while the body trots (measured), and the head is HEAD_RADIUS round; nothing lets it rear.
FOOD_REACH_HEIGHT = 2.3 + HEAD_RADIUS
# A ramp at most this high is walked over (the reference crosses configs/arenas/animalai/
# ramp_and_blocks.yaml's, 0.8 high); a higher one is an obstacle on the grid, as a wall is: the
# reference's flat plan does not climb it. Counted walkable at any height, 30 imported Animal-AI arenas
# whose only way went over ramps 5 units high were valid, and the reference failed every one of them
# it was run on (05-23-02, 05-29-03, 06-18-02, 07-29-01; and 0 of 4 more, behind a ridge of two ramps).
RAMP_WALKABLE_HEIGHT = 1.0
# Terrain: above RAMP_WALKABLE_HEIGHT a ramp is a surface the body walks up when it rises at most
# RAMP_MAX_RISE per unit of its length (experiments/animalai/ramps.md: the gait walks up ramps of 11.3°,
# a rise of 0.2, at 5 and 10 high, and none of 15.9° or more); a steeper one is an obstacle, as a wall
# is. The top of a static box is a surface too (a platform a ramp leads on to, a raised floor the agent
# starts on). Each grid cell has the height of the highest surface over it (:func:`surface_heights`);
# a cell more than TERRAIN_STEP above a neighbour is an edge (a wall's face seen from its top, the side
# of a ramp, a platform's rim) and is blocked, so the body keeps its footprint away from every drop, and
# from the floor it meets the edge as it meets a wall. A walkable ramp's cells rise by at most 0.2 x
# 0.71 a cell (diagonally), under TERRAIN_STEP.
RAMP_MAX_RISE = 0.2
TERRAIN_STEP = 0.3


def z_range(obj: ObjectSpec, z: float | None = None) -> tuple[float, float]:
    centre = obj.position[2] if z is None else z
    return centre - obj.size[2] / 2, centre + obj.size[2] / 2


def pieces(obj: ObjectSpec) -> list[ObjectSpec]:
    """An object as the boxes it is built of (aaai.spec.kinds parts: a tunnel's arch, an L block), each
    as an upright box round that part, in world coordinates; the object itself otherwise."""
    cls = kind_class(obj.kind)
    parts = cls.parts(obj) if cls is not None else None
    if not parts:
        return [obj]
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    boxes = []
    for (x, y, z), (length, width, thickness), roll in parts:
        across = width * abs(math.cos(roll)) + thickness * abs(math.sin(roll))
        up = width * abs(math.sin(roll)) + thickness * abs(math.cos(roll))
        boxes.append(
            ObjectSpec(
                obj.kind,
                "box",
                (obj.position[0] + c * x - s * y, obj.position[1] + s * x + c * y, obj.position[2] + z),
                (length, across, up),
                obj.yaw,
            )
        )
    return boxes


def solids(spec: LevelSpec, owners: list[int] | None = None) -> list[ObjectSpec]:
    """The solid objects, a newer kind made of parts as its pieces; ``owners`` gets each one's
    object index."""
    found = []
    for index, obj in enumerate(spec.objects):
        if obj.kind in SOLID_KINDS:
            for piece in pieces(obj):
                found.append(piece)
                if owners is not None:
                    owners.append(index)
    return found


def overlapping_solids(spec: LevelSpec, index: Solids | None = None) -> list[str]:
    """Pairs of solid objects that overlap (boxes cut into each other), by index and kind; each
    piece is compared with the pieces near it (``index``: the spec's :class:`Solids`)."""
    index = index if index is not None else Solids(spec)
    objs, quads, owners = index.pieces, index.quads, index.owners
    boxes = [index.box(quad) for quad in quads]
    problems = []
    for i in range(len(boxes)):
        for j in index.near(quads[i]):
            if j <= i:
                continue
            if owners[i] != owners[j] and _pieces_overlap(index, boxes, i, j):
                problems.append(
                    f"solid objects overlap: {objs[i].kind} at {_xy(objs[i].position)} "
                    f"and {objs[j].kind} at {_xy(objs[j].position)}"
                )
    return problems


def _pieces_overlap(index: "Solids", boxes: list, i: int, j: int) -> bool:
    """Solid pieces ``i`` and ``j`` of ``index`` cut into each other (``boxes``: their bounding boxes)."""
    lx, ly, hx, hy = boxes[i]
    jx, jy, kx, ky = boxes[j]
    (zi0, zi1), (zj0, zj1) = index.heights[i], index.heights[j]
    return (
        lx < kx - TOLERANCE
        and ly < ky - TOLERANCE
        and jx < hx - TOLERANCE
        and jy < hy - TOLERANCE
        and zi0 < zj1 - TOLERANCE
        and zj0 < zi1 - TOLERANCE
        and footprints_overlap(index.quads[i], index.quads[j])
    )


def exact_overlaps(spec: LevelSpec) -> list[str]:
    """Objects of any kind that fill the very same place (same shape, position, size and yaw, within
    TOLERANCE): a copy-and-paste slip in a hand-made level. Two solids there are reported by
    :func:`overlapping_solids`; two pieces of food or floor are caught here."""
    problems: list[str] = []
    seen: dict[tuple, ObjectSpec] = {}
    for obj in spec.objects:
        key = (obj.shape, *(round(float(v) / TOLERANCE) for v in (*obj.position, *obj.size, obj.yaw)))
        if key in seen and not (obj.kind in SOLID_KINDS and seen[key].kind in SOLID_KINDS):  # (reported below)
            other = seen[key]
            problems.append(
                f"objects overlap exactly: {other.kind} at {_xy(other.position)} and {obj.kind} at {_xy(obj.position)}"
            )
        else:
            seen[key] = obj
    return problems


def food_places(food: ObjectSpec) -> list[tuple[float, float, float]]:
    """Where a piece of food will be: its start, and where a sliding piece stops."""
    moving = behaviour_class(food)
    return [food.position, *(moving.places(food) if moving else [])]


class Solids:
    """The solid pieces of a spec (:func:`solids`), with their footprints and heights, made once, and
    buckets of a grid over their bounding boxes, so that the pieces near a place are found without
    looking at every one: checking n pieces of food against n solids takes time in n, not n**2."""

    MAX_CELLS = 64  # a piece whose box covers more cells than this is in every answer

    def __init__(self, spec: LevelSpec):
        self.owners: list[int] = []  # each piece's object index
        self.pieces = solids(spec, self.owners)
        self.quads = [corners(piece) for piece in self.pieces]
        self.heights = [z_range(piece) for piece in self.pieces]
        self.holes = set(map(tuple, spec.holes))
        self.cell = max(spec.arena_size) / min(256, max(1, math.ceil(math.sqrt(len(self.pieces)))))
        self.buckets: dict[tuple[int, int], list[int]] = {}
        self.everywhere: list[int] = []  # pieces too large for the buckets (or not finite)
        for index, quad in enumerate(self.quads):
            cells = self._cells(quad)
            if cells is None:
                self.everywhere.append(index)
                continue
            for key in cells:
                self.buckets.setdefault(key, []).append(index)

    @staticmethod
    def box(quad) -> tuple[float, float, float, float]:
        """A footprint's bounding box: lowest x and y, highest x and y."""
        xs, ys = [float(p[0]) for p in quad], [float(p[1]) for p in quad]
        return min(xs), min(ys), max(xs), max(ys)

    def _cells(self, quad, most: int = MAX_CELLS) -> list[tuple[int, int]] | None:
        """The grid cells a footprint's bounding box touches (None: more than ``most``)."""
        try:
            i0, j0, i1, j1 = (math.floor(v / self.cell) for v in self.box(quad))
        except (ValueError, OverflowError, ZeroDivisionError):
            return None
        if (i1 - i0 + 1) * (j1 - j0 + 1) > most:
            return None
        return [(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]

    def near(self, quad) -> list[int]:
        """The indices (in order) of every piece whose bounding box may meet ``quad``'s: all those
        :func:`footprints_overlap` could find overlapping it, and a few more."""
        cells = self._cells(quad, most=4 * self.MAX_CELLS)
        if cells is None:
            return list(range(len(self.pieces)))
        found = set(self.everywhere)
        for key in cells:
            found.update(self.buckets.get(key, ()))
        return sorted(found)


def food_problems(spec: LevelSpec, food: ObjectSpec, index: Solids | None = None) -> list[str]:
    """A piece outside the arena, over a hole, floating, or cutting into a solid (``index``: the
    spec's :class:`Solids`, made here if not given)."""
    index = index if index is not None else Solids(spec)
    problems = []
    radius = food.size[0] / 2
    for x, y, z in food_places(food):
        where = f"{food.kind} at {_xy((x, y))}"
        if abs(x) + radius > spec.arena_size[0] / 2 or abs(y) + radius > spec.arena_size[1] / 2:
            problems.append(f"{where} is outside the arena")
            continue
        quad = corners(ObjectSpec(food.kind, "box", (x, y, z), food.size))
        near = index.near(quad)
        slopes = {k: ramp_clearance(index.pieces[k], x, y, z, radius) for k in near if index.pieces[k].kind == "ramp"}
        on_slope = any(clear is not None and abs(clear) < RAMP_REST for clear in slopes.values())
        if spec.heightfield is None and not on_slope and not _supported(spec, x, y, z - radius, index):
            problems.append(f"{where} is not on solid ground")
        for k in near:
            if _food_cuts(index, k, (x, y, z), radius, quad, slopes.get(k)):
                obj = index.pieces[k]
                problems.append(f"{where} cuts into {obj.kind} at {_xy(obj.position)}")
    return problems


def _food_cuts(index: Solids, k: int, place, radius: float, quad, clear: float | None = None) -> bool:
    """A piece of food of ``radius`` at ``place`` (its footprint ``quad``) cuts into solid piece ``k``
    (``clear``: its clearance over a ramp's slope, ramp_clearance, when known)."""
    x, y, z = place
    piece, (low, high) = index.pieces[k], index.heights[k]
    if piece.kind == "ramp":  # a ramp, a wedge: the piece may rest on its slope
        clear = clear if clear is not None else ramp_clearance(piece, x, y, z, radius)
        if clear is not None:
            return clear < -RAMP_REST
        high = low + ramp_height(piece, x, y)  # beside it: as high as its nearest edge
    return low < z + radius - TOLERANCE and z - radius < high - TOLERANCE and footprints_overlap(quad, index.quads[k])


RAMP_REST = 0.05  # units: a sphere this close to a ramp's slope rests on it


def overlaps_earlier(spec: LevelSpec, index: int) -> bool:
    """Whether ``spec.objects[index]`` overlaps an object before it, as Animal-AI's ArenaBuilder
    tests an item before it places it: a solid cutting into an earlier solid or piece of food, or a
    piece of food cutting into an earlier solid or piece of food (its start, as :func:`food_problems`
    measures a cut). Objects after ``index`` are not looked at."""
    earlier = dataclasses.replace(spec, objects=spec.objects[: index + 1])
    index_of = Solids(earlier)
    obj = spec.objects[index]

    def cuts(food: ObjectSpec, owner: int | None) -> bool:
        """``food`` (at its start) cuts into a solid piece: of object ``owner``, or of any other than it (None)."""
        quad = corners(ObjectSpec(food.kind, "box", food.position, food.size))
        return any(
            _food_cuts(index_of, k, food.position, food.size[0] / 2, quad)
            for k in index_of.near(quad)
            if (index_of.owners[k] == owner if owner is not None else index_of.owners[k] != index)
        )

    earlier_food = [other for other in spec.objects[:index] if other.is_food]
    if obj.is_food:
        if cuts(obj, None):
            return True
        return any(
            math.dist(obj.position, other.position) < (obj.size[0] + other.size[0]) / 2 - TOLERANCE
            for other in earlier_food
        )
    if obj.kind not in SOLID_KINDS:
        return False
    if any(cuts(food, index) for food in earlier_food):
        return True
    boxes = [index_of.box(quad) for quad in index_of.quads]
    return any(
        _pieces_overlap(index_of, boxes, i, j)
        for i, owner in enumerate(index_of.owners)
        if owner == index
        for j in index_of.near(index_of.quads[i])
        if index_of.owners[j] != index
    )


def ramp_clearance(ramp: ObjectSpec, x: float, y: float, z: float, radius: float) -> float | None:
    """How far a sphere (centre (x, y, z), ``radius``) whose centre lies over a ramp's footprint is
    clear of its slope, measured upright (negative: it cuts in); None when the centre is not over
    the footprint."""
    u, v = local(ramp, x, y)
    if abs(u) > ramp.size[0] / 2 or abs(v) > ramp.size[1] / 2:
        return None
    rise = ramp.size[2] / ramp.size[0]
    bottom = ramp.position[2] - ramp.size[2] / 2
    return z - radius * math.sqrt(1 + rise * rise) - (bottom + ramp_height(ramp, x, y))


def _supported(spec: LevelSpec, x: float, y: float, bottom: float, index: Solids | None = None) -> bool:
    """Rests on the floor (not over a hole) or on top of a solid object."""
    index = index if index is not None else Solids(spec)
    if abs(bottom) < TOLERANCE:
        return tile_at(spec, x, y) not in index.holes
    point = tuple((x + dx, y + dy) for dx, dy in ((-0.01, -0.01), (0.01, -0.01), (0.01, 0.01), (-0.01, 0.01)))
    for k in index.near(point):
        if abs(index.heights[k][1] - bottom) < TOLERANCE and footprints_overlap(index.quads[k], point):
            return True
    return False


def tile_at(spec: LevelSpec, x: float, y: float) -> tuple[int, int]:
    nx, ny = spec.tiles
    i = int((x + spec.arena_size[0] / 2) / spec.arena_size[0] * nx)
    j = int((y + spec.arena_size[1] / 2) / spec.arena_size[1] * ny)
    return min(max(i, 0), nx - 1), min(max(j, 0), ny - 1)


# --- the occupancy grid ------------------------------------------------------------------
def blocked_grid(spec: LevelSpec) -> np.ndarray:
    """uint8 (rows along y, columns along x), 1 where the agent cannot stand: solids and holes."""
    bridge = spec.bridge
    heights, hard = surface_heights(spec)
    grid = hard.copy()
    grid[edges(heights)] = 1
    raised = heights > TERRAIN_STEP
    if raised.any():  # a top is ground only where the body gets on to it: up a ramp, or starting there
        _, labels = cv2.connectedComponents((grid == 0).astype(np.uint8), connectivity=8)
        reached = set(np.unique(labels[(grid == 0) & ~raised]).tolist())
        if start_ledge(spec) is None:  # (a ledge is stepped down from, never walked on: walk_region)
            reached.add(int(labels[cell(spec, spec.agent.x, spec.agent.y, grid.shape)]))
        reached.discard(0)
        grid[(grid == 0) & raised & ~np.isin(labels, sorted(reached))] = 1
    grid[hazard_grid(spec) == 1] = 1
    if bridge:  # the L10 plank, pushed over, is floor across the trench
        x0, y0, x1, y1 = bridge
        fill(grid, spec, np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)]), value=0)
    return grid


def hazard_grid(spec: LevelSpec) -> np.ndarray:
    """uint8 as :func:`blocked_grid`, 1 only where the floor is missing or deadly and round bad food:
    holes, death zones, and bad food, kept clear of as a solid is."""
    width, height = spec.arena_size
    cols, rows = math.ceil(width / GRID), math.ceil(height / GRID)
    grid = np.zeros((rows, cols), np.uint8)
    for obj in spec.objects:  # a death zone is missing floor; bad food is to be kept clear of, as a solid
        cls = kind_class(obj.kind)
        if cls is not None and (cls.deadly or (cls.edible and cls.value < 0)):
            fill(grid, spec, corners(obj))
    if spec.holes:  # every cell whose centre lies over a missing tile
        nx, ny = spec.tiles
        missing = np.zeros((ny, nx), bool)
        i, j = np.array(spec.holes).T
        missing[j, i] = True
        tile_col = np.minimum(((np.arange(cols) + 0.5) * GRID / (width / nx)).astype(int), nx - 1)
        tile_row = np.minimum(((np.arange(rows) + 0.5) * GRID / (height / ny)).astype(int), ny - 1)
        grid[missing[tile_row][:, tile_col]] = 1
    return grid


_LAST: dict[str, tuple[LevelSpec, Any]] = {}  # what was last made of a spec, by what it is: a level's checks share it


def _memo(name: str, spec: LevelSpec, make: Callable[[], Any]) -> Any:
    """``make()`` for this spec (the very object: a LevelSpec is frozen), made once while it is the last one
    asked about; the arrays it holds are read-only."""
    held = _LAST.get(name)
    if held is None or held[0] is not spec:
        value = make()
        for array in value if isinstance(value, tuple) else (value,):
            array.flags.writeable = False
        _LAST[name] = held = (spec, value)
    return held[1]


def surface_heights(spec: LevelSpec) -> tuple[np.ndarray, np.ndarray]:
    """The terrain (:func:`_surface_heights`), made once per spec; read-only arrays."""
    return _memo("heights", spec, lambda: _surface_heights(spec))


def _surface_heights(spec: LevelSpec) -> tuple[np.ndarray, np.ndarray]:
    """The terrain: float32 heights (rows along y, columns along x) of the highest surface over each
    cell's centre (0: the floor; a static box's top; a walkable ramp's slope), and a uint8 grid, 1 under
    the solids the body never stands on (what moves or is pushed, what is not a box, a ramp steeper than
    RAMP_MAX_RISE). Left out, as the body passes them: what sinks or opens (a passable moving part), a
    ramp at most RAMP_WALKABLE_HEIGHT high (walked over as floor), the plank that becomes a level's
    bridge, and what lies high above the body."""
    width, height = spec.arena_size
    cols, rows = math.ceil(width / GRID), math.ceil(height / GRID)
    heights = np.zeros((rows, cols), np.float32)
    hard = np.zeros((rows, cols), np.uint8)
    xs = (np.arange(cols) + 0.5) * GRID - width / 2
    ys = (np.arange(rows) + 0.5) * GRID - height / 2
    found = []
    for obj in solids(spec):
        moving = behaviour_class(obj)
        if moving and moving.passable:
            continue
        walkable = getattr(kind_class(obj.kind), "walkable", False)
        if walkable and obj.size[2] <= RAMP_WALKABLE_HEIGHT:  # a low ramp
            continue
        if spec.bridge and obj.kind == "plank" and obj.mass > 0:  # it becomes the bridge
            continue
        found.append(obj)
    for obj in sorted(found, key=lambda o: z_range(o)[0]):  # lowest first: what stands on a top sees it
        bottom, top = z_range(obj)
        row, col = covered(spec, corners(obj), heights.shape)
        if bottom > 2 * HEAD_RADIUS and bottom > (heights[row, col].min() if row.size else 0.0) + 2 * HEAD_RADIUS:
            continue  # high above the body wherever it stands under it (a bar, a tunnel's roof)
        walkable = getattr(kind_class(obj.kind), "walkable", False)
        steep = walkable and obj.size[2] > RAMP_MAX_RISE * obj.size[0] + TOLERANCE
        if obj.mass or behaviour_class(obj) or obj.shape != "box" or steep:
            hard[row, col] = 1
            continue
        if walkable:  # the slope over each cell's centre, rising along the ramp's own +x
            c, s = math.cos(obj.yaw), math.sin(obj.yaw)
            u = c * (xs[col] - obj.position[0]) + s * (ys[row] - obj.position[1])
            z = bottom + obj.size[2] * np.clip((u + obj.size[0] / 2) / obj.size[0], 0.0, 1.0)
        else:
            z = np.full(row.shape, top, np.float32)
        heights[row, col] = np.maximum(heights[row, col], z)
    return heights, hard


def covered(spec: LevelSpec, quad, shape) -> tuple[np.ndarray, np.ndarray]:
    """The (rows, columns) of the cells whose centres a quadrilateral covers (as :func:`fill` marks them),
    found in a window round it."""
    x0, y0, x1, y1 = Solids.box(quad)
    row0, col0 = cell(spec, x0 - GRID, y0 - GRID, shape)
    row1, col1 = cell(spec, x1 + GRID, y1 + GRID, shape)
    window = np.zeros((row1 - row0 + 1, col1 - col0 + 1), np.uint8)
    shift = 4
    pixels = (np.asarray(quad) + np.array(spec.arena_size) / 2) / GRID - 0.5 - np.array([col0, row0])
    points = np.round(pixels * (1 << shift)).astype(np.int32)
    cv2.fillConvexPoly(window, points, 1, lineType=cv2.LINE_8, shift=shift)
    row, col = np.nonzero(window)
    return row + row0, col + col0


def edges(heights: np.ndarray) -> np.ndarray:
    """bool: the cells more than TERRAIN_STEP above one of their eight neighbours (a drop beside them)."""
    rows, cols = heights.shape
    around = np.pad(heights, 1, mode="edge")
    found = np.zeros(heights.shape, bool)
    for dr, dc in MOVES:
        found |= heights - around[1 + dr : 1 + dr + rows, 1 + dc : 1 + dc + cols] > TERRAIN_STEP
    return found


def fill(grid: np.ndarray, spec: LevelSpec, quad, value: float = 1) -> None:
    """Marks the cells whose centres a quadrilateral (world x, y) covers."""
    shift = 4
    pixels = (np.asarray(quad) + np.array(spec.arena_size) / 2) / GRID - 0.5  # cell centres at integers
    points = np.round(pixels * (1 << shift)).astype(np.int32)
    cv2.fillConvexPoly(grid, points, value, lineType=cv2.LINE_8, shift=shift)


def distances(free: np.ndarray) -> np.ndarray:
    """float32: the Euclidean distance, in cells, from each free (true, non-zero) cell's centre to the
    nearest cell's centre that is not free (0 there; inf everywhere when every cell is free).

    Exact, and a function of the values alone: scipy's feature transform finds the nearest cell in
    integers, its squared distance is an integer, and the float64 square root, correctly rounded,
    rounded again to float32 is the correctly rounded float32 square root (so the same on every CPU,
    whatever the array's memory layout). OpenCV's ``distanceTransform`` (DIST_L2, DIST_MASK_PRECISE)
    was not: below 2**14 cells it runs Intel IPP's, whose last bits depend on the CPU and on where the
    output lies in memory.
    """
    # imported here: scipy.ndimage takes a sixth of a second to import, which every command would pay
    from scipy.ndimage import distance_transform_edt

    free = np.asarray(free) != 0
    if free.all():
        return np.full(free.shape, np.inf, np.float32)
    return distance_transform_edt(free).astype(np.float32)


def clearance_map(spec: LevelSpec, grid: np.ndarray | None = None) -> np.ndarray:
    """float32: the distance (units) from each cell's centre to the nearest blocked cell or the arena's
    edge (:func:`distances`, exact); of the spec's own grid (``grid`` None), made once per spec and
    read-only."""
    if grid is None:
        return _memo("clearance", spec, lambda: clearance_map(spec, blocked_grid(spec)))
    padded = np.pad(grid, 1, constant_values=1)  # the arena's walls
    return distances(padded == 0)[1:-1, 1:-1] * GRID


# A start on a ledge (an imported Animal-AI start on a dividing wall, aaai.tools.animalai_fit): the body
# starts on a static box's top and steps down from it to the floor on any side, never back up. Measured
# (the gait driven straight at a step, aaai.tools.gait_tuning.follow, 8 to 20 s): it walks off a step up to
# 1.6 high upright in every direction tried (1.7 to 1.9: it stalls on the edge; 2.0 and higher: it falls
# over); it mounts a step of 1.2 or 1.3 with its front feet and never one of 1.5.
LEDGE_DROP = 1.6  # the highest step the body walks down upright
LEDGE_CLIMB = 1.3  # a step up to this high may be mounted: a ledge must be higher
# the body stands on a ledge whose edges are at least this far from the start: its feet at rest reach 4.5
# from the head's centre (the trot's sweep, to FOOTPRINT_RADIUS, may overhang)
LEDGE_FOOTING = 4.5
# the body's centre lands on the floor within this much more than its footprint of the ledge's edge
LEDGE_STEP = 1.0


def start_ledge(spec: LevelSpec) -> ObjectSpec | None:
    """The ledge the agent starts on, if the arena records one (``extras.animalai.start_ledge``: at,
    height) and a static box of that height lies under the start: else None."""
    record = (spec.extras.get("animalai") or {}).get("start_ledge") if isinstance(spec.extras, dict) else None
    if not isinstance(record, dict) or not isinstance(record.get("height"), (int, float)):
        return None
    x, y = spec.agent.x, spec.agent.y
    for obj in solids(spec):
        if obj.mass or obj.behaviour or obj.shape != "box" or getattr(kind_class(obj.kind), "walkable", False):
            continue
        u, v = local(obj, x, y)
        top = obj.position[2] + obj.size[2] / 2
        if abs(u) <= obj.size[0] / 2 and abs(v) <= obj.size[1] / 2 and abs(top - record["height"]) < TOLERANCE:
            return obj
    return None


def ledge_footing(spec: LevelSpec, ledge: ObjectSpec) -> bool:
    """Does the body stand on the ledge: its edges LEDGE_FOOTING or more from the start, its height one
    the body walks down (LEDGE_DROP) and cannot climb back (above LEDGE_CLIMB), its bottom on the floor?"""
    u, v = local(ledge, spec.agent.x, spec.agent.y)
    room = min(ledge.size[0] / 2 - abs(u), ledge.size[1] / 2 - abs(v))
    low, high = z_range(ledge)
    return room >= LEDGE_FOOTING and abs(low) < TOLERANCE and LEDGE_CLIMB < high <= LEDGE_DROP + TOLERANCE


def ledge_landing(spec: LevelSpec, clearance: np.ndarray, ledge: ObjectSpec, footprint: float, separate: bool = False):
    """Where the body walks after stepping down from the ledge: every region of cells clear for its
    footprint that comes within ``footprint`` + LEDGE_STEP of the ledge's edge, on any side (bool grid;
    ``separate``: a list, one grid a region); None if it does not stand on the ledge or no floor lies next
    to it. The ledge is never in it: the floor does not lead back up, so the body walks in one of them."""
    if not ledge_footing(spec, ledge):
        return None
    free = (clearance > footprint).astype(np.uint8)
    _, labels = cv2.connectedComponents(free, connectivity=8)
    top = np.zeros(clearance.shape, np.uint8)
    fill(top, spec, corners(ledge))
    near = distances(top == 0) * GRID <= footprint + LEDGE_STEP
    floor = surface_heights(spec)[0] <= TERRAIN_STEP  # down on the floor: not the ledge's top, nor a higher one
    landing = np.unique(labels[near & (free > 0) & (top == 0) & floor])
    landing = landing[landing > 0]
    if separate:
        return [labels == label for label in landing] or None
    return np.isin(labels, landing) if landing.size else None


def walk_region(
    spec: LevelSpec,
    clearance: np.ndarray,
    start: tuple[float, float] | None = None,
    footprint: float = FOOTPRINT_RADIUS,
) -> np.ndarray | None:
    """Where the body's centre can walk from ``start`` (default: the agent's start) as a bool grid:
    cells whose disc of ``footprint`` (the body's footprint radius: the quadruped's FOOTPRINT_RADIUS,
    or another body's, aaai.task.arena.footprint_for) is clear, in the start's connected region;
    None if the start is not clear. The agent's start on a ledge (:func:`start_ledge`): the regions it
    steps down into (:func:`ledge_landing`)."""
    if start is None:
        ledge = start_ledge(spec)
        if ledge is not None:  # the floor next to the ledge the start is on, on any side
            return ledge_landing(spec, clearance, ledge, footprint)
    free = (clearance > footprint).astype(np.uint8)
    _, labels = cv2.connectedComponents(free, connectivity=8)
    x, y = (spec.agent.x, spec.agent.y) if start is None else start
    row, col = cell(spec, x, y, clearance.shape)
    start = labels[row, col]
    return None if start == 0 else labels == start


def reachable_region(
    spec: LevelSpec,
    grid: np.ndarray | None = None,
    footprint: float = FOOTPRINT_RADIUS,
    clearance: np.ndarray | None = None,
) -> tuple[np.ndarray, bool]:
    """Where the head's centre can get to from the start (a bool grid), and whether the start is clear.

    The body walks where a disc of ``footprint`` (default FOOTPRINT_RADIUS) is clear, in the start's
    connected region; from there it can push its head on to any place with REACH_CLEARANCE (for another
    footprint, that footprint less the same FOOTPRINT_RADIUS - REACH_CLEARANCE). ``clearance``: the
    grid's clearance map if already made (else made here).
    """
    clearance = clearance_map(spec, grid) if clearance is None else clearance
    walk = walk_region(spec, clearance, footprint=footprint)
    if walk is None:
        return np.zeros_like(clearance, bool), False
    return _reach(walk, clearance, footprint), True


def reach_regions(spec: LevelSpec, footprint: float = FOOTPRINT_RADIUS) -> list[np.ndarray]:
    """The places the head can get to, one grid for each region the body may end up in: from a start on a
    ledge (:func:`start_ledge`), one for each region it may step down into (it takes one, and never
    climbs back); else the one :func:`reachable_region` (none when the start is not clear)."""
    ledge = start_ledge(spec)
    clearance = clearance_map(spec)
    if ledge is None:
        region, clear = reachable_region(spec, footprint=footprint, clearance=clearance)
        return [region] if clear else []
    walks = ledge_landing(spec, clearance, ledge, footprint, separate=True) or []
    return [_reach(walk, clearance, footprint) for walk in walks]


def _reach(walk: np.ndarray, clearance: np.ndarray, footprint: float) -> np.ndarray:
    """Where the head's centre gets to from the cells the body's centre walks (``walk``)."""
    reach = footprint - (FOOTPRINT_RADIUS - REACH_CLEARANCE)
    lean = round((FOOTPRINT_RADIUS - REACH_CLEARANCE) / GRID) + 1
    leaned = cv2.dilate(
        walk.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * lean + 1, 2 * lean + 1))
    )
    return (leaned > 0) & (clearance > reach)


# The eight moves on the grid, (rows, columns), and half the length in units of each: a move costs its
# length times the mean of its two cells' costs, (length * 0.5) * (cost + cost of the other cell).
MOVES = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
HALF_LENGTHS = [GRID * math.hypot(dr, dc) * 0.5 for dr, dc in MOVES]


def path_costs(region: np.ndarray, goals: np.ndarray, cell_cost: np.ndarray | None = None) -> np.ndarray:
    """Cost of the cheapest 8-connected path inside ``region`` from every cell to the nearest goal
    cell (inf where none leads there, and everywhere when no goal lies in the region), in units: each
    move costs its length times the mean ``cell_cost`` (default 1; not negative, inf where never to
    be entered) of its two cells. Dijkstra's algorithm (scipy's csgraph) from all the goals at once,
    on the graph of the region's cells and their eight neighbours: a move's cost is the float64
    ``(GRID * hypot(dr, dc) * 0.5) * (cost[cell] + cost[neighbour])`` and a cell's the least sum of
    them on a path from a goal: a plan is the same float for float whatever order cells are visited in.
    """
    # imported here: scipy.sparse takes a fifth of a second to import, which every command would pay
    from scipy.sparse import csr_array
    from scipy.sparse.csgraph import dijkstra

    rows, cols = region.shape
    n = rows * cols
    sources = np.flatnonzero(goals & region)
    if sources.size == 0:
        return np.full(region.shape, math.inf)
    cost = np.ones(region.shape) if cell_cost is None else np.asarray(cell_cost, dtype=np.float64)
    inside = np.zeros((rows + 2, cols + 2), bool)  # a border of cells outside, so each move is a slice
    inside[1:-1, 1:-1] = region
    around = np.zeros((rows + 2, cols + 2))
    around[1:-1, 1:-1] = cost
    moves = len(MOVES)
    edge = np.empty((moves, rows, cols), bool)  # a move from this cell stays in the region
    weight = np.empty((moves, rows, cols))
    for m, (dr, dc) in enumerate(MOVES):
        there = slice(1 + dr, 1 + dr + rows), slice(1 + dc, 1 + dc + cols)
        np.logical_and(inside[there], region, out=edge[m])
        np.add(cost, around[there], out=weight[m])
        weight[m] *= HALF_LENGTHS[m]
    offsets = np.array([dr * cols + dc for dr, dc in MOVES], np.int32)
    edges = edge.reshape(moves, n).T  # cell by cell, as CSR holds them
    neighbours = (np.arange(n, dtype=np.int32)[:, None] + offsets)[edges]
    starts = np.zeros(n + 1, np.int32)
    np.cumsum(edge.sum(0, dtype=np.int32).ravel(), out=starts[1:])
    # explicit zeros (cells of cost 0) stay edges in a CSR graph; only a dense one drops them
    graph = csr_array((weight.reshape(moves, n).T[edges], neighbours, starts), shape=(n, n))
    return dijkstra(graph, directed=True, indices=sources, min_only=True).reshape(rows, cols)


def cell(spec: LevelSpec, x: float, y: float, shape) -> tuple[int, int]:
    """The grid cell (row, column) holding the point (x, y), clamped to the grid."""
    col = min(max(math.floor((x + spec.arena_size[0] / 2) / GRID), 0), shape[1] - 1)
    row = min(max(math.floor((y + spec.arena_size[1] / 2) / GRID), 0), shape[0] - 1)
    return row, col


# units/s: the quadruped at its fastest, for a bouncing piece's timing (the gait walks 2.7 on open floor)
WALK_SPEED = 3.0


def walk_speed(footprint: float) -> float | None:
    """The speed a body validated with ``footprint`` is timed at (:func:`food_reachable`): the walking
    bodies' WALK_SPEED; None (any speed) for another footprint, the sphere's, many times as fast."""
    return WALK_SPEED if footprint == FOOTPRINT_RADIUS else None


def food_reachable(spec: LevelSpec, region: np.ndarray, food: ObjectSpec, speed: float | None = WALK_SPEED) -> bool:
    """Can the head, its centre in the agent's region, touch the piece where it comes to rest? Only
    from where the body stands at most FOOD_REACH_HEIGHT below the piece's bottom (not on a pole or a
    block it cannot climb; on a platform it walks on to, yes: :func:`surface_heights`); a piece on what
    sinks (a pillar that brings it down) counts as on the floor. (From a top it does not reach down to
    the floor beside it: the region keeps the body's footprint from the top's rim.) A piece that never
    comes to rest (a bouncing one) is reachable if it is at its start or at any place of its path
    within the level's time limit (:meth:`aaai.spec.behaviours.Behaviour.path`): it passes where the
    body can wait for it, if the body, walking straight at ``speed`` (None: any speed), could be there
    by then (a piece that falls out of reach in the first seconds, far from the start, is not
    reachable at its start)."""
    path = path_of(spec, food)
    if not path:
        return _reachable_at(spec, region, food, food_places(food)[-1])
    timed = [(0.0, food.position), *(((i + 1) * PATH_EVERY, place) for i, place in enumerate(path))]
    return any(
        _in_time(spec, food, place, seconds, speed) and _reachable_at(spec, region, food, place)
        for seconds, place in timed
    )


def _in_time(spec: LevelSpec, food: ObjectSpec, place, seconds: float, speed: float | None) -> bool:
    """Could the body, from its start, walking straight at ``speed``, touch the piece at ``place``
    within ``seconds``?"""
    if speed is None:
        return True
    reach = FOOTPRINT_RADIUS + HEAD_RADIUS + food.size[0] / 2
    return math.dist((spec.agent.x, spec.agent.y), place[:2]) - reach <= speed * seconds


PATHS_KEPT = 64  # paths path_of keeps: a file's checks ask for each piece's many times (every region, every pass mark)
_paths: dict[str, list] = {}


def path_of(spec: LevelSpec, food: ObjectSpec) -> list[tuple[float, float, float]]:
    """The piece's path within the level's time limit (:meth:`aaai.spec.behaviours.Behaviour.path`,
    within the spec's :class:`aaai.sim.geometry.Bounds`), worked out once for the piece, the arena and
    its objects, and kept for the last PATHS_KEPT asked."""
    moving = behaviour_class(food)
    if moving is None:
        return []
    key = repr((food, spec.time_limit, spec.arena_size, spec.objects))
    if key not in _paths:
        if len(_paths) >= PATHS_KEPT:
            del _paths[next(iter(_paths))]
        _paths[key] = moving.path(food, Bounds(spec), spec.time_limit)
    return _paths[key]


def _reachable_at(spec: LevelSpec, region: np.ndarray, food: ObjectSpec, place) -> bool:
    """:func:`food_reachable` for the piece at ``place`` (x, y, z)."""
    x, y, z = place
    bottom = z - food.size[2] / 2
    if bottom > FOOD_REACH_HEIGHT and _on_sinking(spec, x, y):
        bottom = 0.0
    reach = HEAD_RADIUS + food.size[0] / 2 + GRID
    row0, col0 = cell(spec, x - reach, y - reach, region.shape)
    row1, col1 = cell(spec, x + reach, y + reach, region.shape)
    window = region[row0 : row1 + 1, col0 : col1 + 1]
    cols = (np.arange(col0, col1 + 1) + 0.5) * GRID - spec.arena_size[0] / 2
    rows = (np.arange(row0, row1 + 1) + 0.5) * GRID - spec.arena_size[1] / 2
    near = window & (np.hypot(cols[None, :] - x, rows[:, None] - y) <= reach)
    if not near.any():
        return False
    stand = surface_heights(spec)[0][row0 : row1 + 1, col0 : col1 + 1]
    return bool(np.any(near & (bottom - stand <= FOOD_REACH_HEIGHT)))


def _on_sinking(spec: LevelSpec, x: float, y: float) -> bool:
    """Does (x, y) lie over an object that sinks out of the way (a passable moving part)?"""
    for obj in spec.objects:
        moving = behaviour_class(obj)
        if moving and moving.passable:
            u, v = local(obj, x, y)
            if abs(u) <= obj.size[0] / 2 and abs(v) <= obj.size[1] / 2:
                return True
    return False


MAX_HEIGHTS = 400 * 400  # samples of a heightfield (L11 uses 65 x 65), as many as floor tiles may be
MAX_TIME_LIMIT = 1000.0  # seconds: an arena file's longest episode (Animal-AI's 1000 steps at scale 7.8)
MAX_ARENA = 1000.0  # units across: far beyond any level, short of a grid that would not fit in memory


def malformed(spec: LevelSpec) -> list[str]:
    """Numbers and fields no level can be built from: non-finite or non-positive sizes, positions
    that are not finite, holes outside the tiles, behaviours missing their fields."""
    problems = []

    def finite(values, what: str) -> bool:
        try:
            ok = all(math.isfinite(float(v)) for v in values)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            problems.append(f"{what} is not a list of finite numbers: {values!r}")
        return ok

    if finite(spec.arena_size, "the arena size") and not all(0 < v <= MAX_ARENA for v in spec.arena_size):
        problems.append(f"the arena size {spec.arena_size!r} must lie between 0 and {MAX_ARENA:g} on each side")
    if finite((spec.agent.x, spec.agent.y, spec.agent.yaw), "the agent's pose") and not all(
        abs(v) <= MAX_ARENA / 2 for v in (spec.agent.x, spec.agent.y)
    ):
        problems.append(
            f"the agent's start ({spec.agent.x:.4g}, {spec.agent.y:.4g}) lies outside any arena "
            f"(allowed: -{MAX_ARENA / 2:g} to {MAX_ARENA / 2:g} on each axis)"
        )
    if finite((spec.time_limit,), "the time limit") and not 0.2 <= spec.time_limit <= MAX_TIME_LIMIT:
        problems.append(
            f"the time limit {spec.time_limit!r} must lie between 0.2 and {MAX_TIME_LIMIT:g} seconds, as an arena "
            "file's (a generated level's: at most 200)"
        )
    if spec.heightfield is not None:
        rows = spec.heightfield
        widths = {len(row) for row in rows}
        if len(rows) < 2 or len(widths) != 1 or not 2 <= min(widths) or len(rows) * min(widths) > MAX_HEIGHTS:
            problems.append(
                f"the heightfield has rows of {sorted(widths)} heights in {len(rows)} rows; allowed: 2 or more rows, "
                f"each of the same number (2 or more) of heights, {MAX_HEIGHTS:,} heights in all"
            )
        elif finite([v for row in rows for v in row], "the heightfield") and any(
            abs(v) > MAX_ARENA for row in rows for v in row
        ):
            problems.append(
                f"a height of the heightfield lies beyond {MAX_ARENA:g} (allowed: -{MAX_ARENA:g} to {MAX_ARENA:g})"
            )
    nx, ny = spec.tiles
    if not (isinstance(nx, int) and isinstance(ny, int) and 1 <= nx <= 400 and 1 <= ny <= 400):
        problems.append(f"the floor tiles {spec.tiles!r} must be two integers from 1 to 400")
    elif any(not (0 <= i < nx and 0 <= j < ny) for i, j in spec.holes):
        problems.append(f"a hole lies outside the {nx} x {ny} floor tiles: {spec.holes!r}")
    for index, obj in enumerate(spec.objects):
        what = f"object {index} ({obj.kind})"
        if finite(obj.size, f"{what}'s size") and min(obj.size) <= 0:
            problems.append(f"{what}'s size {obj.size!r} must be positive")
        if finite((*obj.position, obj.yaw, obj.mass), f"{what}'s position, yaw and mass") and not all(
            abs(v) <= MAX_ARENA
            for v in (*obj.position, *(obj.size if all(isinstance(v, (int, float)) for v in obj.size) else ()))
        ):
            problems.append(
                f"{what}'s position {tuple(float(f'{v:.4g}') for v in obj.position)!r} or size lies "
                f"far outside any arena (allowed: -{MAX_ARENA:g} to {MAX_ARENA:g})"
            )
        if obj.behaviour:
            name = obj.behaviour.get("type") if isinstance(obj.behaviour, dict) else None
            moving = REGISTRY.get(name) if isinstance(name, str) else None
            if moving is None:
                problems.append(f"{what}'s behaviour {obj.behaviour!r} is not one of {', '.join(REGISTRY)}")
                continue
            missing = [f for f in moving.fields if f not in obj.behaviour]
            if missing:
                problems.append(f"{what}'s behaviour {obj.behaviour['type']!r} lacks {', '.join(missing)}")
        cls = kind_class(obj.kind)
        if obj.timing is not None and not (cls is not None and cls.timed):
            problems.append(
                f"{what} has timing {obj.timing!r}; allowed: timing only on "
                f"{', '.join(k for k, c in REGISTRY_KINDS.items() if c.timed)}"
            )
        if cls is not None and not problems:
            problems += [f"{what}: {problem}" for problem in cls.problems(obj)]
    return problems


def check(spec: LevelSpec, require_food: bool = True, footprint: float = FOOTPRINT_RADIUS) -> list[str]:
    """Every problem found in a spec; an empty list means the level is valid. A hand-made spec
    may leave food out (``require_food=False``); a generated level may not. ``footprint`` is the
    body's footprint radius (default the quadruped's, FOOTPRINT_RADIUS; aaai.task.arena.footprint_for)."""
    problems = malformed(spec)
    if problems:  # nothing else can be measured on it
        return problems
    index = Solids(spec)  # made once, for the solids and every piece of food
    problems = exact_overlaps(spec) + overlapping_solids(spec, index)
    for food in spec.foods:
        problems += food_problems(spec, food, index)
    region, clear = reachable_region(spec, footprint=footprint)
    if not clear and start_ledge(spec) is not None:
        problems.append(
            f"the agent's start {_xy((spec.agent.x, spec.agent.y))} on a ledge is not clear: the body stands on "
            f"a ledge whose edges are {LEDGE_FOOTING:g} or more from the start, above {LEDGE_CLIMB:g} and at most "
            f"{LEDGE_DROP:g} high, with floor next to it where a body of radius {footprint} fits"
        )
        return problems
    if not clear:
        problems.append(
            f"the agent's start {_xy((spec.agent.x, spec.agent.y))} is not clear: a body of "
            f"radius {footprint} there meets a solid, a hole or the arena's edge"
        )
        return problems
    for food in spec.foods:
        if not food_reachable(spec, region, food, walk_speed(footprint)):
            problems.append(f"{food.kind} at {_xy(food_places(food)[-1])} cannot be reached from the start")
    if require_food and not spec.foods:
        problems.append("the level has no food")
    return problems


def _xy(position) -> str:
    return f"({position[0]:.1f}, {position[1]:.1f})"
