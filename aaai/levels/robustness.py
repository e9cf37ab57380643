"""L6 Robustness: a random other level and cell, with every object kind recoloured to one of a
few randomly generated colours, and walls taller with the L6 difficulty."""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from aaai.spec import LevelSpec, generator_fields
from aaai.spec.kinds import COLOURS, OBJECT_KINDS

PARAMETERS = ("colours", "wall_height")
WRAPS_OTHER_LEVELS = True  # the registry hands generate() an ``inner`` level maker
WALL_KINDS = ("wall", "transparent_wall")


def generate(p: dict, rng: np.random.Generator, inner: Callable[[np.random.Generator], LevelSpec]) -> dict:
    spec = inner(rng)
    palette = rng.uniform(0.0, 1.0, (int(p["colours"]), 3))
    # each kind keeps its own opacity, so transparent walls stay see-through
    colours = {kind: (*map(float, palette[int(rng.integers(len(palette)))]), COLOURS[kind][3]) for kind in OBJECT_KINDS}
    fields = generator_fields(spec)
    fields["objects"] = [_restyle(obj, colours, p["wall_height"]) for obj in spec.objects]
    fields["wall_height"] = max(spec.wall_height, float(p["wall_height"]))
    fields["colours"] = {kind: tuple(rgba) for kind, rgba in colours.items()}
    return fields


def _restyle(obj, colours: dict, wall_height: float):
    """The object in its kind's new colour; a wall at least wall_height tall, on the same base."""
    obj = replace(obj, colour=colours[obj.kind])
    if obj.kind in WALL_KINDS and obj.size[2] < wall_height:
        bottom = obj.position[2] - obj.size[2] / 2
        obj = replace(
            obj,
            position=(obj.position[0], obj.position[1], bottom + wall_height / 2),
            size=(obj.size[0], obj.size[1], wall_height),
        )
    return obj
