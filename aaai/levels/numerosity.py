"""L9 Numerosity: four sectors around the agent, each holding a random number of food pieces;
entering a sector closes its opening behind the agent, so it must pick the one with the most."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import PlacementError, arena_walls, slab, sphere
from aaai.spec import ObjectSpec

PARAMETERS = ("hub", "max_pieces", "food_size", "door_depth", "wall_height")
ARENA = (70.0, 70.0)  # room for the body to turn in a sector without a foot touching its walls
DIRECTIONS = {"north": (0.0, 1.0), "east": (1.0, 0.0), "south": (0.0, -1.0), "west": (-1.0, 0.0)}
SPOKE_END = ARENA[0] / 2 - 0.5  # a spoke's end, short of the arena's corner so it stays inside
TRIES = 200
# A piece's centre stays FOOD_WALL_GAP from the arena's wall and SPOKE_GAP / sqrt(2) from a spoke's
# middle, so that the head eats it, and backs away, clear of the walls.
FOOD_WALL_GAP = 5.0
SPOKE_GAP = 9.0


def generate(p: dict, rng: np.random.Generator) -> dict:
    hub, height = float(p["hub"]), float(p["wall_height"])
    counts = _counts(rng, int(p["max_pieces"]))
    objects = arena_walls(ARENA, height) + _spokes(hub, height)
    foods = []
    for (name, direction), count in zip(DIRECTIONS.items(), counts):
        objects.append(_door(direction, hub, height, float(p["door_depth"])))
        foods += _sector_food(rng, direction, count, hub + 1.0 + float(p["door_depth"]), float(p["food_size"]))
    best = max(range(4), key=lambda k: counts[k])
    value = foods[0].food_value if foods else 0.0
    return {
        "agent": (0.0, 0.0, float(rng.uniform(-math.pi, math.pi))),
        "objects": objects + foods,
        "max_food_reward": counts[best] * value,  # the agent can eat in one sector only
        "wall_height": height,
        "arena_size": ARENA,
        "extras": {"sector_food": dict(zip(DIRECTIONS, counts)), "best_sector": list(DIRECTIONS)[best]},
    }


def _counts(rng: np.random.Generator, most: int) -> list[int]:
    """Pieces per sector, 0..most each, with one sector holding strictly the most."""
    for _ in range(TRIES):
        counts = [int(c) for c in rng.integers(0, most + 1, size=4)]
        if counts.count(max(counts)) == 1:
            return counts
    raise PlacementError(f"no unique most-food sector in {TRIES} draws")


def _spokes(hub: float, height: float) -> list[ObjectSpec]:
    """Walls on the diagonals from the hub's corners to the arena's corners: the sector borders."""
    length = (SPOKE_END - hub) * math.sqrt(2)
    middle = (hub + SPOKE_END) / 2
    return [
        slab("wall", sx * middle, sy * middle, length, 1.0, height, yaw=math.atan2(sy, sx))
        for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))
    ]


def _door(direction: tuple[float, float], hub: float, height: float, depth: float) -> ObjectSpec:
    """The wall that closes a sector's opening (the hub's side) once the agent's head is
    ``depth`` past it inside the sector; until then it is hidden."""
    ux, uy = direction
    centre = hub + 0.5
    trigger = {"type": "door", "direction": [ux, uy], "distance": hub + 1.0 + depth}
    return slab(
        "wall", ux * centre, uy * centre, 2 * hub - 2.0, 1.0, height, yaw=math.atan2(ux, -uy), behaviour=trigger
    )


def _sector_food(rng: np.random.Generator, direction, count: int, near: float, size: float) -> list[ObjectSpec]:
    """``count`` yellow pieces in a sector, past the door's trigger line, apart from each other."""
    ux, uy = direction
    far = ARENA[0] / 2 - FOOD_WALL_GAP  # the head eats it from the open side, clear of the wall
    pieces: list[tuple[float, float]] = []
    for _ in range(count):
        for _ in range(TRIES):
            along = float(rng.uniform(near + 4.0, far))  # eaten only from inside the trigger line
            across = float(rng.uniform(-(along - SPOKE_GAP), along - SPOKE_GAP))  # clear of the spokes
            x, y = ux * along - uy * across, uy * along + ux * across
            if all(math.hypot(x - a, y - b) >= size + 1.5 for a, b in pieces):
                pieces.append((x, y))
                break
        else:
            raise PlacementError(f"no room for {count} pieces in a sector")
    return [sphere("food_yellow", x, y, size) for x, y in pieces]
