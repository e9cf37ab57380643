"""L11 Body awareness: rough terrain (a heightfield of seeded smooth noise) and one green far
from the agent, so walking itself is the challenge."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np

from aaai.levels.common import AGENT_RADIUS, arena_walls, sample_clear_point, sphere

PARAMETERS = ("amplitude", "roughness", "samples", "food_distance", "food_size", "wall_height")
ARENA = (50.0, 50.0)


def terrain(rng: np.random.Generator, roughness: int, samples: int, amplitude: float) -> np.ndarray:
    """Heights (rows along y, columns along x) from -amplitude to 0: a roughness x roughness grid
    of uniform noise, smoothly (bicubic) resized to samples x samples and stretched to the range."""
    coarse = rng.uniform(0.0, 1.0, (roughness, roughness)).astype(np.float64)
    smooth = cv2.resize(coarse, (samples, samples), interpolation=cv2.INTER_CUBIC)
    low, high = smooth.min(), smooth.max()
    return np.round(amplitude * ((smooth - low) / max(high - low, 1e-9) - 1.0), 3)


def height_at(heights: np.ndarray, x: float, y: float) -> float:
    """The terrain's height at (x, y), interpolated between samples as Bullet does (bilinear)."""
    rows, cols = heights.shape
    u = (x + ARENA[0] / 2) / ARENA[0] * (cols - 1)
    v = (y + ARENA[1] / 2) / ARENA[1] * (rows - 1)
    i, j = min(int(u), cols - 2), min(int(v), rows - 2)
    fu, fv = u - i, v - j
    top = heights[j, i] * (1 - fu) + heights[j, i + 1] * fu
    bottom = heights[j + 1, i] * (1 - fu) + heights[j + 1, i + 1] * fu
    return float(top * (1 - fv) + bottom * fv)


def generate(p: dict, rng: np.random.Generator) -> dict:
    amplitude = float(p["amplitude"])
    heights = terrain(rng, int(p["roughness"]), int(p["samples"]), amplitude)
    agent_x, agent_y = sample_clear_point(rng, ARENA, AGENT_RADIUS + 1.0, [])
    size = float(p["food_size"])
    food_x, food_y = sample_clear_point(rng, ARENA, size / 2 + 1.0, [(agent_x, agent_y, p["food_distance"])])
    # resting on the highest ground under it, so it never sinks into a slope
    ground = max(
        height_at(heights, food_x + dx, food_y + dy)
        for dx in (-size / 2, 0, size / 2)
        for dy in (-size / 2, 0, size / 2)
    )
    food = replace(sphere("food_green", food_x, food_y, size), position=(food_x, food_y, ground + size / 2))
    return {
        "agent": (agent_x, agent_y, float(rng.uniform(-math.pi, math.pi))),
        "objects": arena_walls(ARENA, float(p["wall_height"]), bottom=-amplitude - 0.5) + [food],
        "max_food_reward": food.food_value,
        "heightfield": tuple(tuple(float(h) for h in row) for row in heights),
    }
