"""L0 Initial food contact: one green piece straight ahead of an agent facing north."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import arena_walls, sphere

PARAMETERS = ("agent_y", "food_distance", "food_offset", "food_size")


def generate(p: dict, rng: np.random.Generator) -> dict:
    size = float(p["food_size"])
    offset = float(rng.uniform(-p["food_offset"], p["food_offset"]))
    food = sphere("food_green", offset, p["agent_y"] + p["food_distance"], size)
    return {
        "agent": (0.0, float(p["agent_y"]), math.pi / 2),
        "objects": arena_walls((50.0, 50.0), 4.0) + [food],
        "max_food_reward": food.food_value,
    }
