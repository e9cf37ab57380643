"""L7 Internal models: a random other level and cell, seen through a camera that goes dark for a
while every few seconds (the rays stay on), so the agent must keep a model of where things are."""
from __future__ import annotations

import numpy as np

PARAMETERS = ("light_seconds", "dark_seconds")
WRAPS_OTHER_LEVELS = True


def generate(p: dict, d: int, rng: np.random.Generator, seeds: range) -> dict:
    from aaai.levels import other_level, spec_fields  # the registry imports this module

    fields = spec_fields(other_level(rng, exclude=(6, 7), seeds=seeds))
    # the environment blanks the camera on this schedule (aaai.env), in simulated time
    fields["extras"]["blackout"] = {"light": float(p["light_seconds"]), "dark": float(p["dark_seconds"])}
    return fields
