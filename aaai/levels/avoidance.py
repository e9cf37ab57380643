"""L4 Avoidance: a floor of n x n tiles with some left out (holes: falling in costs 1 and ends
the episode) and a few walls; the agent must reach the green without falling."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import AGENT_RADIUS, arena_walls, place_slabs, sample_clear_point, sphere

PARAMETERS = ("tiles", "holes", "walls", "wall_length_min", "wall_length_max", "food_size", "food_distance")
ARENA = (50.0, 50.0)


def generate(p: dict, rng: np.random.Generator) -> dict:
    n = int(p["tiles"])
    tile = ARENA[0] / n
    agent_tile = (int(rng.integers(1, n - 1)), int(rng.integers(1, n - 1)))  # not against a wall
    agent_x, agent_y = (_centre(agent_tile[0], tile), _centre(agent_tile[1], tile))
    size = float(p["food_size"])
    keep_out = [(agent_x, agent_y, p["food_distance"])]
    food_x, food_y = sample_clear_point(rng, ARENA, size / 2 + 1.0, keep_out)
    food_tile = (int((food_x + ARENA[0] / 2) // tile), int((food_y + ARENA[1] / 2) // tile))
    # no hole under the food, nor on or beside the agent's tile (it would start at a hole's edge)
    banned = {food_tile} | {(agent_tile[0] + di, agent_tile[1] + dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)}
    free = [(i, j) for i in range(n) for j in range(n) if (i, j) not in banned]
    chosen = rng.choice(len(free), size=int(p["holes"]), replace=False)
    holes = tuple(sorted(free[int(k)] for k in chosen))
    food = sphere("food_green", food_x, food_y, size)
    walls = arena_walls(ARENA, 4.0)
    inner = [
        {
            "kind": "wall",
            "length": float(rng.uniform(p["wall_length_min"], p["wall_length_max"])),
            "thickness": 1.0,
            "height": 4.0,
        }
        for _ in range(int(p["walls"]))
    ]
    keep_out = [(agent_x, agent_y, AGENT_RADIUS + 1.5), (food_x, food_y, size / 2 + 4.0)]
    return {
        "agent": (agent_x, agent_y, float(rng.uniform(-math.pi, math.pi))),
        "objects": walls + place_slabs(rng, ARENA, inner, walls, keep_out) + [food],
        "max_food_reward": food.food_value,
        "tiles": (n, n),
        "holes": holes,
    }


def _centre(index: int, tile: float) -> float:
    return -ARENA[0] / 2 + (index + 0.5) * tile
