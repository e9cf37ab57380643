"""L2b Delayed gratification: a small green ahead; a larger yellow on a pillar that sinks to the
floor. Waiting for the yellow, then eating the green, pays most."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import arena_walls, sphere
from aaai.spec import ObjectSpec

PARAMETERS = (
    "agent_y",
    "green_distance",
    "green_size",
    "yellow_size",
    "pillar_height",
    "pillar_diameter",
    "pillar_offset_min",
    "pillar_offset_max",
    "sink_seconds",
)
ARENA = (50.0, 50.0)


def generate(p: dict, rng: np.random.Generator) -> dict:
    green = sphere("food_green", 0.0, p["agent_y"] + p["green_distance"], p["green_size"])
    side = 1 if rng.random() < 0.5 else -1
    x = side * float(rng.uniform(p["pillar_offset_min"], p["pillar_offset_max"]))
    y = float(p["agent_y"] + p["green_distance"] + rng.uniform(-4.0, 4.0))
    height, size = float(p["pillar_height"]), float(p["yellow_size"])
    sink = {"type": "sink", "depth": height, "duration": float(p["sink_seconds"])}
    pillar = ObjectSpec(
        "pillar", "cylinder", (x, y, height / 2), (p["pillar_diameter"],) * 2 + (height,), behaviour=sink
    )
    yellow = ObjectSpec("food_yellow", "sphere", (x, y, height + size / 2), (size,) * 3, behaviour=sink)
    return {
        "agent": (0.0, float(p["agent_y"]), math.pi / 2),
        "objects": arena_walls(ARENA, 4.0) + [pillar, green, yellow],
        # the yellow (it does not end the episode) once it is low enough, then the green
        "max_food_reward": green.food_value + yellow.food_value,
        "extras": {"sink_seconds": float(p["sink_seconds"])},
    }
