"""L2 Y-maze: a stem opening onto two arms; a large green in one arm, above difficulty 5 a
smaller green in the other. Only one green can be eaten, so the agent must pick the better arm."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import arena_walls, slab, sphere

PARAMETERS = (
    "stem_width",
    "stem_length",
    "divider_start",
    "agent_y",
    "food_size_min",
    "food_size_max",
    "second_food",
    "second_food_size",
)
ARENA = (50.0, 50.0)
HEIGHT = 4.0


def generate(p: dict, rng: np.random.Generator) -> dict:
    half = ARENA[1] / 2
    stem_x = p["stem_width"] / 2 + 0.5  # wall centres; the corridor between them is stem_width wide
    stem_y = -half + p["stem_length"] / 2
    divider = half - p["divider_start"]
    walls = [
        slab("wall", -stem_x, stem_y, p["stem_length"], 1.0, HEIGHT, yaw=math.pi / 2),
        slab("wall", stem_x, stem_y, p["stem_length"], 1.0, HEIGHT, yaw=math.pi / 2),
        # the divider between the arms runs from divider_start to the north wall
        slab("wall", 0.0, p["divider_start"] + divider / 2, divider, 1.0, HEIGHT, yaw=math.pi / 2),
    ]
    arm = 1 if rng.random() < 0.5 else -1
    foods = [_arm_food(rng, arm, float(rng.uniform(p["food_size_min"], p["food_size_max"])), p)]
    if p["second_food"]:
        foods.append(_arm_food(rng, -arm, float(p["second_food_size"]), p))
    return {
        "agent": (0.0, float(p["agent_y"]), math.pi / 2),
        "objects": arena_walls(ARENA, HEIGHT) + walls + foods,
        "max_food_reward": max(food.food_value for food in foods),  # one green ends the episode
        "extras": {"best_arm": "east" if arm > 0 else "west"},
    }


def _arm_food(rng: np.random.Generator, arm: int, size: float, p: dict):
    """A green piece in the east (arm = 1) or west arm, well inside it."""
    x = arm * float(rng.uniform(8.0, 17.0))
    y = float(rng.uniform(p["divider_start"] + 6.0, ARENA[1] / 2 - 6.0))
    return sphere("food_green", x, y, size)
