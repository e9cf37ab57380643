"""Pieces that level generators share: arena walls, slabs, spheres and collision-free placement."""

from __future__ import annotations

import math

import numpy as np

from aaai.sim.geometry import TOLERANCE, Quad, corners, distance_to_footprint, footprints_overlap  # noqa: F401
from aaai.spec import ObjectSpec

WALL_THICKNESS = 1.0
AGENT_RADIUS = 4.5  # the resting X reaches 4.5 from the head's centre
MAX_TRIES = 1000


class PlacementError(RuntimeError):
    """A generator could not place its objects; the message names the level and seed."""


def arena_walls(size: tuple[float, float], height: float, bottom: float = 0.0) -> list[ObjectSpec]:
    """Four walls around a floor of ``size`` centred on the origin, inner faces on its edges.

    ``bottom`` below 0 lets the walls reach down to a terrain that dips below z = 0.
    """
    half_x, half_y = size[0] / 2, size[1] / 2
    t = WALL_THICKNESS
    spans = [
        ((0.0, half_y + t / 2), (size[0] + 2 * t, t)),
        ((0.0, -half_y - t / 2), (size[0] + 2 * t, t)),
        ((half_x + t / 2, 0.0), (t, size[1])),
        ((-half_x - t / 2, 0.0), (t, size[1])),
    ]
    tall = height - bottom
    return [ObjectSpec("wall", "box", (x, y, bottom + tall / 2), (sx, sy, tall)) for (x, y), (sx, sy) in spans]


def slab(
    kind: str, x: float, y: float, length: float, thickness: float, height: float, yaw: float = 0.0, **extra
) -> ObjectSpec:
    """An upright box standing on the floor: ``length`` along its yaw, ``thickness`` across it."""
    return ObjectSpec(kind, "box", (x, y, height / 2), (length, thickness, height), yaw=yaw, **extra)


def place_slabs(
    rng: np.random.Generator,
    size: tuple[float, float],
    slabs: list[dict],
    existing: list[ObjectSpec],
    keep_out: list[tuple[float, float, float]],
    gap: float = 1.0,
) -> list[ObjectSpec]:
    """Upright slabs (dicts of slab() arguments but x, y, yaw) at random places and headings, each
    inside the arena, ``gap`` clear of every existing object and of the others, and outside every
    circle (x, y, r) of keep_out."""
    placed: list[ObjectSpec] = []
    for spec in slabs:
        reach = spec["length"] / 2 + 0.5
        for _ in range(MAX_TRIES):
            x = float(rng.uniform(-size[0] / 2 + reach, size[0] / 2 - reach))
            y = float(rng.uniform(-size[1] / 2 + reach, size[1] / 2 - reach))
            candidate = slab(x=x, y=y, yaw=float(rng.uniform(0, math.pi)), **spec)
            quad = corners(candidate)
            if all(distance_to_footprint(candidate, cx, cy) >= r for cx, cy, r in keep_out) and not any(
                footprints_overlap(quad, corners(o), gap) for o in existing + placed
            ):
                placed.append(candidate)
                break
        else:
            raise PlacementError(
                f"no place for a {spec['kind']} of length {spec['length']:.1f} after {MAX_TRIES} tries"
            )
    return placed


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
