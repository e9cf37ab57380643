"""L3 Obstacles: a transparent wall ahead hides a green just behind it; pushable planks and more
transparent walls, growing in size and number with difficulty, stand in the way."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import AGENT_RADIUS, arena_walls, place_slabs, slab, sphere

PARAMETERS = (
    "agent_y",
    "agent_x_range",
    "wall_distance",
    "wall_width",
    "wall_height",
    "food_behind",
    "food_size_min",
    "food_size_max",
    "obstacles",
    "obstacle_length_min",
    "obstacle_length_max",
    "obstacle_height_min",
    "obstacle_height_max",
    "plank_mass",
)
ARENA = (50.0, 50.0)


def generate(p: dict, rng: np.random.Generator) -> dict:
    agent_x = float(rng.uniform(-p["agent_x_range"], p["agent_x_range"]))
    wall_y = p["agent_y"] + p["wall_distance"]
    glass = slab("transparent_wall", agent_x, wall_y, p["wall_width"], 1.0, p["wall_height"])
    size = float(rng.uniform(p["food_size_min"], p["food_size_max"]))
    food = sphere("food_green", agent_x, wall_y + 0.5 + p["food_behind"], size)
    extra = []
    for index in range(int(p["obstacles"])):  # half planks (pushable), half transparent walls
        plank = index % 2 == 0
        extra.append(
            {
                "kind": "plank" if plank else "transparent_wall",
                "length": float(rng.uniform(p["obstacle_length_min"], p["obstacle_length_max"])),
                "thickness": 1.0,
                "height": float(rng.uniform(p["obstacle_height_min"], p["obstacle_height_max"])),
                "mass": float(p["plank_mass"]) if plank else 0.0,
            }
        )
    walls = arena_walls(ARENA, 4.0)
    keep_out = [(agent_x, p["agent_y"], AGENT_RADIUS + 1.5), (*food.position[:2], size / 2 + 4.0)]
    obstacles = place_slabs(rng, ARENA, extra, walls + [glass], keep_out)
    return {
        "agent": (agent_x, float(p["agent_y"]), math.pi / 2),
        "objects": walls + [glass] + obstacles + [food],
        "max_food_reward": food.food_value,
    }
