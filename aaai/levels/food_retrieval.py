"""L1 Basic food retrieval: one green and some yellow pieces, some moving, random heading."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import AGENT_RADIUS, arena_walls, sample_clear_point, sphere
from aaai.spec import ObjectSpec

PARAMETERS = ("pieces", "size_min", "size_max", "move_probability", "speed", "min_separation", "agent_clearance")
ARENA = (50.0, 50.0)


def generate(p: dict, rng: np.random.Generator) -> dict:
    agent_x, agent_y = sample_clear_point(rng, ARENA, AGENT_RADIUS + 1.0, [])
    heading = float(rng.uniform(-math.pi, math.pi))
    foods: list[ObjectSpec] = []
    for index in range(int(p["pieces"])):
        size = float(rng.uniform(p["size_min"], p["size_max"]))
        keep_out = [(agent_x, agent_y, AGENT_RADIUS + p["agent_clearance"] + size / 2)]
        keep_out += [(*food.position[:2], p["min_separation"]) for food in foods]
        x, y = sample_clear_point(rng, ARENA, size / 2 + 0.5, keep_out)
        moving = rng.random() < p["move_probability"]
        behaviour = {"type": "random_walk", "speed": float(p["speed"])} if moving else None
        kind = "food_green" if index == 0 else "food_yellow"
        foods.append(sphere(kind, x, y, size, behaviour=behaviour))
    return {
        "agent": (agent_x, agent_y, heading),
        "objects": arena_walls(ARENA, 4.0) + foods,
        "max_food_reward": sum(food.food_value for food in foods),
    }
