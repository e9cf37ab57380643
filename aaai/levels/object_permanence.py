"""L8 Object permanence: a green piece slides from one side behind a central occluding wall.
Behind the wall a barrier splits the arena's back half: the food's side, and a pit of missing
floor (deadly below) on the other. The agent must remember which side the food went."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import arena_walls, slab, sphere

PARAMETERS = (
    "arena_x",
    "arena_y",
    "tile",
    "agent_y",
    "agent_x_range",
    "occluder_length",
    "occluder_height",
    "food_size",
    "food_y",
    "food_start_x",
    "food_stop_x",
    "speed",
    "pit_depth",
)


def generate(p: dict, rng: np.random.Generator) -> dict:
    arena = (float(p["arena_x"]), float(p["arena_y"]))
    half_y = arena[1] / 2
    side = 1 if rng.random() < 0.5 else -1  # the food's side: east (+1) or west
    occluder = slab("wall", 0.0, 0.0, p["occluder_length"], 1.0, p["occluder_height"])
    barrier_length = half_y - 0.5
    barrier = slab("wall", 0.0, 0.5 + barrier_length / 2, barrier_length, 1.0, p["occluder_height"], yaw=math.pi / 2)
    slide = {"type": "slide", "to": [side * float(p["food_stop_x"]), float(p["food_y"])], "speed": float(p["speed"])}
    food = sphere("food_green", side * float(p["food_start_x"]), p["food_y"], p["food_size"], behaviour=slide)
    tiles, holes = _pit(arena, float(p["tile"]), -side, p["occluder_length"] / 2, float(p["pit_depth"]))
    agent_x = float(rng.uniform(-p["agent_x_range"], p["agent_x_range"]))
    return {
        "agent": (agent_x, float(p["agent_y"]), math.pi / 2),
        "objects": arena_walls(arena, 4.0) + [occluder, barrier, food],
        "max_food_reward": food.food_value,
        "arena_size": arena,
        "tiles": tiles,
        "holes": holes,
        "extras": {"food_side": "east" if side > 0 else "west"},
    }


def _pit(arena: tuple[float, float], tile: float, side: int, reach: float, depth: float):
    """Floor tiles and the holes that make the pit: behind the occluder on ``side``, from the
    barrier to the occluder's end, ``depth`` deep from the occluder's back."""
    nx, ny = round(arena[0] / tile), round(arena[1] / tile)
    holes = []
    for i in range(nx):
        x0 = -arena[0] / 2 + i * tile
        for j in range(ny):
            y0 = -arena[1] / 2 + j * tile
            near, far = sorted((side * x0, side * (x0 + tile)))
            if 0.5 <= near and far <= reach and 0.5 <= y0 and y0 + tile <= 0.5 + depth:
                holes.append((i, j))
    return (nx, ny), tuple(holes)
