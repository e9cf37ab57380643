"""L7 Internal models: a random other level and cell, seen through a camera that goes dark for a
while every few seconds (the rays stay on), so the agent must keep a model of where things are."""

from __future__ import annotations

from typing import Callable

import numpy as np

from aaai.spec import Blackout, LevelSpec, generator_fields

PARAMETERS = ("light_seconds", "dark_seconds")
WRAPS_OTHER_LEVELS = True  # the registry hands generate() an ``inner`` level maker


def generate(p: dict, rng: np.random.Generator, inner: Callable[[np.random.Generator], LevelSpec]) -> dict:
    fields = generator_fields(inner(rng))
    # the camera goes dark on this schedule (aaai.sim.sensors.Blackout), in simulated time
    fields["blackout"] = Blackout(float(p["light_seconds"]), float(p["dark_seconds"]))
    return fields
