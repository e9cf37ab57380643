"""L10 Causal reasoning: a trench of missing floor (deadly below) across the arena; the green is
on the far side; an upright plank stands at the trench's edge, hinged at its bottom edge on the
trench's side, and pushed over it falls across the trench as a bridge. Walls beside the plank
from difficulty 4 (two from 8)."""

from __future__ import annotations

import math

import numpy as np

from aaai.levels.common import AGENT_RADIUS, MAX_TRIES, PlacementError, arena_walls, slab, sphere

PARAMETERS = (
    "trench_width",
    "trench_south",
    "plank_width",
    "plank_thickness",
    "plank_overhang",
    "plank_mass",
    "plank_x_range",
    "side_walls",
    "side_wall_length",
    "transparent_probability",
    "food_size",
)
ARENA = (50.0, 50.0)
LANE_MARGIN = 2.5  # a side wall's middle this far beyond the plank's edge: a lane 15 wide, so
# the trotting body (feet out to 5) walks up to the plank without touching either wall
EDGE_GAP = 3.0  # between the standing plank and the trench's edge: the fallen plank rests on this much floor


def generate(p: dict, rng: np.random.Generator) -> dict:
    width, south = int(p["trench_width"]), int(p["trench_south"])  # whole 1 x 1 tiles
    north = south + width
    holes = tuple((i, j) for i in range(int(ARENA[0])) for j in range(south + 25, north + 25))
    plank_x = float(rng.uniform(-p["plank_x_range"], p["plank_x_range"]))
    thick, across = float(p["plank_thickness"]), float(p["plank_width"])
    length = width + EDGE_GAP + float(p["plank_overhang"])  # standing height = fallen length
    face = south - EDGE_GAP  # the plank's north face; it tips north about its bottom edge here
    hinge = {"type": "hinge", "pivot": [[plank_x - across / 2, face, 0.0], [plank_x + across / 2, face, 0.0]]}
    plank = slab(
        "plank", plank_x, face - thick / 2, across, thick, length, mass=float(p["plank_mass"]), behaviour=hinge
    )
    bridge = [plank_x - across / 2, face, plank_x + across / 2, face + length]
    walls = _side_walls(
        rng,
        int(p["side_walls"]),
        plank_x,
        across,
        face,
        float(p["side_wall_length"]),
        float(p["transparent_probability"]),
    )
    size = float(p["food_size"])
    keep_out = [(plank_x, y, across / 2 + size / 2 + 1.0) for y in np.arange(face, face + length + 1, 2.0)]
    food_x, food_y = _point_between(rng, north + size / 2 + 3.0, ARENA[1] / 2 - size / 2 - 1.0, size, keep_out)
    agent_x, agent_y = _point_between(
        rng,
        -ARENA[1] / 2 + AGENT_RADIUS + 1.0,
        face - 8.0,
        AGENT_RADIUS + 1.0,
        [(w.position[0], w.position[1], w.size[0] / 2 + AGENT_RADIUS + 1.0) for w in walls],
    )
    return {
        "agent": (agent_x, agent_y, math.pi / 2 + float(rng.uniform(-math.pi / 4, math.pi / 4))),
        "objects": arena_walls(ARENA, 4.0) + [plank] + walls + [sphere("food_green", food_x, food_y, size)],
        "max_food_reward": sphere("food_green", 0, 0, size).food_value,
        "tiles": (int(ARENA[0]), int(ARENA[1])),
        "holes": holes,
        "bridge": tuple(bridge) if bridge else None,
        "extras": {"trench": [south, north]},
    }


def _side_walls(
    rng, count: int, plank_x: float, across: float, face: float, length: float, transparent_probability: float
) -> list:
    """Walls along the approach on one or both sides of the plank, each transparent with the
    given probability; they leave a lane wide enough for the body."""
    sides = [1, -1] if count >= 2 else ([1 if rng.random() < 0.5 else -1] if count == 1 else [])
    walls = []
    for side in sides:
        kind = "transparent_wall" if rng.random() < transparent_probability else "wall"
        x = plank_x + side * (across / 2 + LANE_MARGIN)
        walls.append(slab(kind, x, face - length / 2, length, 1.0, 4.0, yaw=math.pi / 2))
    return walls


def _point_between(rng, y_low: float, y_high: float, margin: float, keep_out) -> tuple[float, float]:
    """A point with y in [y_low, y_high], ``margin`` inside the side walls, outside keep_out circles."""
    for _ in range(MAX_TRIES):
        x = float(rng.uniform(-ARENA[0] / 2 + margin, ARENA[0] / 2 - margin))
        y = float(rng.uniform(y_low, y_high))
        if all(math.hypot(x - cx, y - cy) >= r for cx, cy, r in keep_out):
            return x, y
    raise PlacementError(f"no point with y in [{y_low:.1f}, {y_high:.1f}] after {MAX_TRIES} tries")
