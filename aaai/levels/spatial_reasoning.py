"""L5 Spatial reasoning: a maze over a grid of square chunks, carved by a seeded depth-first
search; the agent and the green lie in the two chunks farthest apart along the maze."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from aaai.levels.common import AGENT_RADIUS, arena_walls, place_slabs, sphere
from aaai.sim.geometry import merge_tiles
from aaai.spec import ObjectSpec

PARAMETERS = (
    "chunks",
    "chunk_size",
    "wall_height",
    "obstacles",
    "obstacle_length_min",
    "obstacle_length_max",
    "food_size",
)
THICKNESS = 1.0
OBSTACLE_KINDS = ("plank", "transparent_wall", "wall")


def generate(p: dict, rng: np.random.Generator) -> dict:
    count, chunk, height = int(p["chunks"]), float(p["chunk_size"]), float(p["wall_height"])
    columns = math.ceil(math.sqrt(count))
    rows = math.ceil(count / columns)
    cells = [(i % columns, i // columns) for i in range(count)]  # the last row may be short
    passages = carve(cells, rng)
    start, goal = farthest_pair(cells, passages)
    arena = (columns * chunk, rows * chunk)
    walls = arena_walls(arena, height) + maze_walls(columns, rows, cells, passages, chunk, height)
    agent_x, agent_y = _chunk_point(start, arena, chunk, rng)
    food_x, food_y = _chunk_point(goal, arena, chunk, rng)
    food = sphere("food_green", food_x, food_y, p["food_size"])
    extra = []
    for index in range(int(p["obstacles"])):
        kind = OBSTACLE_KINDS[index % len(OBSTACLE_KINDS)]
        extra.append(
            {
                "kind": kind,
                "length": float(rng.uniform(p["obstacle_length_min"], p["obstacle_length_max"])),
                "thickness": 1.0,
                "height": 4.0,
                "mass": 10.0 if kind == "plank" else 0.0,
            }
        )
    keep_out = [(agent_x, agent_y, AGENT_RADIUS + 1.5), (food_x, food_y, p["food_size"] / 2 + 4.0)]
    obstacles = place_slabs(rng, arena, extra, walls, keep_out)
    return {
        "agent": (agent_x, agent_y, float(rng.uniform(-math.pi, math.pi))),
        "objects": walls + obstacles + [food],
        "max_food_reward": food.food_value,
        "arena_size": arena,
        "wall_height": height,
        "extras": {
            "maze": {"columns": columns, "rows": rows, "chunks": count, "start": list(start), "goal": list(goal)}
        },
    }


def carve(cells: list[tuple[int, int]], rng: np.random.Generator) -> set[frozenset]:
    """A perfect maze over the cells (randomised depth-first search): the set of open passages."""
    present = set(cells)
    seen, stack, passages = {cells[0]}, [cells[0]], set()
    while stack:
        x, y = stack[-1]
        nexts = [n for n in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)) if n in present and n not in seen]
        if not nexts:
            stack.pop()
            continue
        step = nexts[int(rng.integers(len(nexts)))]
        passages.add(frozenset(((x, y), step)))
        seen.add(step)
        stack.append(step)
    return passages


def farthest_pair(cells: list[tuple[int, int]], passages: set[frozenset]) -> tuple[tuple, tuple]:
    """The two cells farthest apart along the maze (first found wins a tie)."""
    best = (-1, cells[0], cells[0])
    for source in cells:
        distance, queue = {source: 0}, deque([source])
        while queue:
            cell = queue.popleft()
            for passage in passages:
                if cell in passage:
                    (other,) = passage - {cell}
                    if other not in distance:
                        distance[other] = distance[cell] + 1
                        queue.append(other)
        far = max(cells, key=lambda c: distance[c])
        if distance[far] > best[0]:
            best = (distance[far], source, far)
    return best[1], best[2]


def maze_walls(columns: int, rows: int, cells, passages, chunk: float, height: float) -> list[ObjectSpec]:
    """The inner walls as few non-overlapping boxes.

    A block grid alternates chunk interiors with wall lines (odd indices); a wall line's block is
    solid unless it is an open passage, a crossing is solid where any wall meets it. Merging the
    solid blocks into rectangles (as the floor's tiles) gives disjoint boxes.
    """
    present = set(cells)
    nx, ny = 2 * columns - 1, 2 * rows - 1

    def solid(i: int, j: int) -> bool:
        if i % 2 == 0 and j % 2 == 0:
            return False  # a chunk's interior (an unused chunk stays closed by its walls)
        if i % 2 == 1 and j % 2 == 1:
            return any(
                solid(a, b) for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)) if 0 <= a < nx and 0 <= b < ny
            )
        a, b = ((i - 1) // 2, j // 2), ((i + 1) // 2, j // 2)
        if i % 2 == 0:
            a, b = (i // 2, (j - 1) // 2), (i // 2, (j + 1) // 2)
        both = a in present and b in present
        return not (both and frozenset((a, b)) in passages)

    free = {(i, j) for i in range(nx) for j in range(ny) if not solid(i, j)}
    edges_x, edges_y = _block_edges(columns, chunk), _block_edges(rows, chunk)
    half_x, half_y = columns * chunk / 2, rows * chunk / 2
    walls = []
    for i0, j0, i1, j1 in merge_tiles(nx, ny, free):
        x0, x1, y0, y1 = edges_x[i0], edges_x[i1], edges_y[j0], edges_y[j1]
        walls.append(
            ObjectSpec(
                "wall", "box", ((x0 + x1) / 2 - half_x, (y0 + y1) / 2 - half_y, height / 2), (x1 - x0, y1 - y0, height)
            )
        )
    return walls


def _block_edges(count: int, chunk: float) -> list[float]:
    """Edges of the blocks along one axis, from the arena's edge: interiors and wall lines alternate."""
    edges = [0.0]
    for k in range(2 * count - 1):
        if k % 2 == 0:
            edges.append((k // 2 + 1) * chunk - THICKNESS / 2)
        else:
            edges.append((k // 2 + 1) * chunk + THICKNESS / 2)
    return edges[:-1] + [count * chunk]


def _chunk_point(
    cell: tuple[int, int], arena: tuple[float, float], chunk: float, rng: np.random.Generator
) -> tuple[float, float]:
    """A point near the middle of a chunk."""
    x = -arena[0] / 2 + (cell[0] + 0.5) * chunk + float(rng.uniform(-chunk / 6, chunk / 6))
    y = -arena[1] / 2 + (cell[1] + 0.5) * chunk + float(rng.uniform(-chunk / 6, chunk / 6))
    return x, y
