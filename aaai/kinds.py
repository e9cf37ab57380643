"""The kinds of object in a level: one list, used by the builder, rays, rewards and viewer."""
from __future__ import annotations

KINDS = (
    "food_green",  # eaten on contact; ends the episode
    "food_yellow",  # eaten on contact; disappears, the episode goes on
    "wall",
    "transparent_wall",
    "floor",
    "deadly_floor",  # ends the episode with -1
    "plank",  # pushable
    "pillar",
    "hole",  # seen by rays only: the edge of missing floor (a hole, pit or trench) in a ray's direction
)
KIND_INDEX = {kind: index for index, kind in enumerate(KINDS)}
RAY_ONLY_KINDS = ("hole",)
OBJECT_KINDS = tuple(kind for kind in KINDS if kind not in RAY_ONLY_KINDS)
FOOD_KINDS = ("food_green", "food_yellow")
SOLID_KINDS = ("wall", "transparent_wall", "plank", "pillar")

# Default RGBA per kind (transparent walls are drawn see-through).
COLOURS = {
    "food_green": (0.1, 0.8, 0.1, 1.0),
    "food_yellow": (0.95, 0.8, 0.1, 1.0),
    "wall": (0.55, 0.55, 0.6, 1.0),
    "transparent_wall": (0.7, 0.85, 1.0, 0.3),
    "floor": (0.8, 0.75, 0.65, 1.0),
    "deadly_floor": (0.8, 0.1, 0.1, 1.0),
    "plank": (0.55, 0.35, 0.15, 1.0),
    "pillar": (0.4, 0.4, 0.45, 1.0),
    "hole": (0.15, 0.1, 0.1, 1.0),
}


def check_kind(kind: str) -> str:
    """An object's kind: one of OBJECT_KINDS (a hole is missing floor tiles, not an object)."""
    if kind not in OBJECT_KINDS:
        raise ValueError(f"object kind {kind!r} is not known; allowed: {', '.join(OBJECT_KINDS)}")
    return kind
