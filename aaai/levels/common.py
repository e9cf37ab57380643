"""Pieces that level generators share: arena walls and collision-free placement."""
from __future__ import annotations

import math

import numpy as np

from aaai.spec import ObjectSpec

WALL_THICKNESS = 1.0
AGENT_RADIUS = 4.5  # the resting X reaches 4.5 from the head's centre
MAX_TRIES = 1000


class PlacementError(RuntimeError):
    """A generator could not place its objects; the message names the level and seed."""


def arena_walls(size: tuple[float, float], height: float) -> list[ObjectSpec]:
    """Four walls around a floor of ``size`` centred on the origin, inner faces on its edges."""
    half_x, half_y = size[0] / 2, size[1] / 2
    t = WALL_THICKNESS
    spans = [
        ((0.0, half_y + t / 2), (size[0] + 2 * t, t)),
        ((0.0, -half_y - t / 2), (size[0] + 2 * t, t)),
        ((half_x + t / 2, 0.0), (t, size[1])),
        ((-half_x - t / 2, 0.0), (t, size[1])),
    ]
    return [
        ObjectSpec("wall", "box", (x, y, height / 2), (sx, sy, height)) for (x, y), (sx, sy) in spans
    ]


def sphere(kind: str, x: float, y: float, diameter: float, **extra) -> ObjectSpec:
    """A food piece (or ball) resting on the floor."""
    return ObjectSpec(kind, "sphere", (x, y, diameter / 2), (diameter,) * 3, **extra)


def sample_clear_point(
    rng: np.random.Generator,
    size: tuple[float, float],
    margin: float,
    keep_out: list[tuple[float, float, float]],
) -> tuple[float, float]:
    """A point at least ``margin`` inside the arena and outside every circle (x, y, r) of keep_out."""
    half_x, half_y = size[0] / 2 - margin, size[1] / 2 - margin
    for _ in range(MAX_TRIES):
        x, y = rng.uniform(-half_x, half_x), rng.uniform(-half_y, half_y)
        if all(math.hypot(x - cx, y - cy) >= r for cx, cy, r in keep_out):
            return float(x), float(y)
    raise PlacementError(f"no point {margin} inside the arena clear of {len(keep_out)} circles after {MAX_TRIES} tries")
